#pragma once
// Detector images split by path criteria, in the same run as the plain images.
//
// Every complete path of every ray (root to leaf, tracer/records/path_history.h) that ends in a
// detector hit is tested against each criterion (skipping those a PathSummary of the path
// rules out, analysis/criteria/criteria.h); its flux goes into that criterion's image of that
// detector when it matches, and into the "rest" image when it matches none. Images are filled in
// ray order, so they are the same for any thread count, and each ray's contributions are added
// once per image (per-ray statistics, like the plain images). In one process a ray is added as
// soon as every lower ray has arrived: memory is the images plus the rays in flight. Across
// ranks each rank keeps its rays' hits (24 bytes a detected path) until finish().

#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "analysis/criteria/criteria.h"
#include "tracer/records/detector.h"
#include "tracer/transport/branch_filter.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

class CriterionImages {
  public:
    // `detectors`: empty images of the run (as given to traceNonsequential); `detectorOfObject`
    // maps object ids to detector indices, `nextDetector` each detector to the next one on the
    // same object (TransportView's; empty: one detector an object).
    CriterionImages(std::vector<std::string> criterionTexts,
                    std::vector<CompiledCriterion> criteria,
                    const std::vector<DetectorImage>& detectors, std::vector<int> detectorOfObject,
                    std::vector<int> nextDetector = {});

    // The onRay callback for traceNonsequential (thread-safe). everyRay: the callback sees
    // every ray index from 0 on, each once (one process); the rays are then added as they
    // complete in order. Otherwise (a rank's share) they wait for finish().
    RayCallback callback(bool everyRay);
    // Adds everything collected, in ray order. Call once after the trace. Traced across
    // ranks: every rank calls it, and rank 0 adds all ranks' rays (the others' images stay
    // empty).
    void finish(const Ranks& ranks = Ranks::alone());

    // A checkpoint's part (one process, everyRay): `f(nextRay, images)` under the lock, the
    // rays below nextRay being in the images.
    void withState(
        const std::function<void(uint64_t, const std::vector<std::vector<DetectorImage>>&)>& f)
        const {
        std::lock_guard<std::mutex> lock(mutex_);
        f(nextRay_, images_);
    }
    // Goes on from a checkpoint's state (before the trace, after callback(true)): the rays below
    // nextRay are in `images` and are ignored when traced again. Throws std::invalid_argument
    // when the images are not this run's layers.
    void restore(uint64_t nextRay, std::vector<std::vector<DetectorImage>> images);
    // Rays collected and not added yet (with everyRay, those ahead of a ray still in flight).
    size_t pendingRays() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return pending_.size();
    }
    size_t criterionCount() const { return texts_.size(); }
    const std::vector<CompiledCriterion>& criteria() const { return criteria_; }
    const std::string& text(size_t c) const { return texts_[c]; }
    // images[c][d]: criterion c (c == criterionCount() is "the rest") on detector d.
    const std::vector<std::vector<DetectorImage>>& images() const { return images_; }

  private:
    struct Hit {
        int layer;
        int detector;
        int pixel;
        double flux;
    };
    void collect(uint64_t ray, const PathHistory& h);
    // Adds the pending rays from the front of pending_ on, in order, while they are the next
    // ones (all of them: to the end). Under mutex_.
    void addPending(bool all);

    std::vector<std::string> texts_;
    std::vector<CompiledCriterion> criteria_;
    std::vector<int> detectorOfObject_, nextDetector_;
    std::vector<std::vector<DetectorImage>> images_;
    mutable std::mutex mutex_;
    std::map<uint64_t, std::vector<Hit>> pending_;  // everyRay: also rays without hits
    bool everyRay_ = false;
    uint64_t nextRay_ = 0;                               // everyRay: the lowest ray not added yet
    uint64_t resumeBelow_ = 0;  // restored: the rays below this are in the images already
    std::vector<std::vector<RayContribution>> scratch_;  // [layer][detector]
};

}  // namespace veil

namespace veil {

// Online pruning by criteria (tracer/transport/branch_filter.h): a branch is traced on while at
// least one criterion may still be true for it, and culled as soon as all are false. A branch's
// state is one EvaluatorBank buffer, so the copy at every split is a single allocation.
class CriteriaFilter : public BranchFilter {
  public:
    explicit CriteriaFilter(const std::vector<CompiledCriterion>& criteria) : bank_(criteria) {}
    std::unique_ptr<BranchState> start() const override;

  private:
    EvaluatorBank bank_;  // refers to the caller's criteria, which must outlive the filter
};

}  // namespace veil
