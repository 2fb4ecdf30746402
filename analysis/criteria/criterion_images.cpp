#include "analysis/criteria/criterion_images.h"

#include <stdexcept>

#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/transport/interaction.h"

namespace veil {

CriterionImages::CriterionImages(std::vector<std::string> criterionTexts,
                                 std::vector<CompiledCriterion> criteria,
                                 const std::vector<DetectorImage>& detectors,
                                 std::vector<int> detectorOfObject, std::vector<int> nextDetector)
    : texts_(std::move(criterionTexts)),
      criteria_(std::move(criteria)),
      detectorOfObject_(std::move(detectorOfObject)),
      nextDetector_(std::move(nextDetector)),
      images_(texts_.size() + 1, detectors),
      scratch_(images_.size(), std::vector<RayContribution>(detectors.size())) {}

RayCallback CriterionImages::callback(bool everyRay) {
    everyRay_ = everyRay;
    return [this](uint64_t ray, const PathHistory& h) { collect(ray, h); };
}

void CriterionImages::restore(uint64_t nextRay, std::vector<std::vector<DetectorImage>> images) {
    if (!everyRay_)
        throw std::invalid_argument("CriterionImages::restore: only a one-process trace goes on");
    bool same = images.size() == images_.size();
    for (size_t l = 0; same && l < images.size(); ++l) {
        same = images[l].size() == images_[l].size();
        for (size_t d = 0; same && d < images[l].size(); ++d)
            same = images[l][d].geometry().pixelCount() == images_[l][d].geometry().pixelCount();
    }
    if (!same) throw std::invalid_argument("CriterionImages::restore: not this run's layers");
    std::lock_guard<std::mutex> lock(mutex_);
    images_ = std::move(images);
    nextRay_ = resumeBelow_ = nextRay;
}

void CriterionImages::addPending(bool all) {
    while (!pending_.empty()) {
        const auto front = pending_.begin();
        if (!all && front->first != nextRay_) return;
        for (const Hit& h : front->second) scratch_[h.layer][h.detector].add(h.pixel, h.flux);
        for (size_t l = 0; l < scratch_.size(); ++l)
            for (size_t d = 0; d < scratch_[l].size(); ++d)
                if (!scratch_[l][d].empty()) images_[l][d].add(scratch_[l][d]);
        nextRay_ = front->first + 1;
        pending_.erase(front);
    }
}

void CriterionImages::collect(uint64_t ray, const PathHistory& h) {
    if (ray < resumeBelow_) return;  // a resumed run's ray, added before
    std::vector<Hit> hits;
    std::vector<NodeIndex> chain;
    std::vector<PathEvent> events;
    std::vector<std::pair<int, int>> pixels;  // detector, pixel
    std::vector<int> layers;
    thread_local std::vector<StreamingEvaluator> evaluators;
    thread_local PathSummary summary;
    evaluators.clear();
    for (const CompiledCriterion& c : criteria_) evaluators.emplace_back(c);
    for (size_t i = 0; i < h.size(); ++i) {
        const auto leaf = static_cast<NodeIndex>(i);
        if (!h.isLeaf(leaf)) continue;
        const PathNode& end = h.node(leaf);
        if (end.type != EventType::DetectorHit) continue;
        if (end.object < 0 || end.object >= static_cast<int>(detectorOfObject_.size())) continue;
        const int first = detectorOfObject_[end.object];
        if (first < 0) continue;
        // Every detector on the object that has the hit in a pixel records it.
        pixels.clear();
        for (int d = first; d >= 0; d = nextDetectorOf(nextDetector_, d))
            if (const auto pixel = images_[0][d].pixelOf(end.position))
                pixels.push_back({d, *pixel});
        if (pixels.empty()) continue;
        const PathView view = h.path(leaf, chain);
        events.clear();
        summary.reset();
        for (size_t k = 0; k < view.size(); ++k) {
            events.push_back(view.event(k));
            summary.add(events.back());
        }
        layers.clear();
        for (size_t c = 0; c < criteria_.size(); ++c) {
            // Most criteria (one per ghost) need an event this path lacks: skip their
            // evaluator, whose answer would be false.
            if (!summary.mayMatch(criteria_[c])) continue;
            StreamingEvaluator& ev = evaluators[c];
            ev.reset();
            for (size_t k = 0; k < events.size() && !ev.decided(); ++k) ev.push(events[k]);
            if (ev.finish() == CriterionState::True) layers.push_back(static_cast<int>(c));
        }
        if (layers.empty()) layers.push_back(static_cast<int>(criteria_.size()));
        for (const auto& [d, pixel] : pixels)
            for (const int c : layers) hits.push_back({c, d, pixel, end.flux});
    }
    if (hits.empty() && !everyRay_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    pending_[ray] = std::move(hits);
    if (everyRay_) addPending(false);
}

void CriterionImages::finish(const Ranks& ranks) {
    if (!ranks.single()) {
        ByteWriter w;
        w.put(static_cast<uint64_t>(pending_.size()));
        for (const auto& [ray, hits] : pending_) {
            w.put(ray);
            w.putVector(hits);
        }
        const std::vector<Bytes> all = ranks.gatherToRoot(w.take());
        if (!ranks.root()) {
            pending_.clear();
            return;
        }
        for (size_t r = 1; r < all.size(); ++r) {
            ByteReader in(all[r]);
            const uint64_t n = in.get<uint64_t>();
            for (uint64_t i = 0; i < n; ++i) {
                const uint64_t ray = in.get<uint64_t>();
                pending_[ray] = in.getVector<Hit>();
            }
        }
    }
    addPending(true);
}

}  // namespace veil

namespace veil {

namespace {

class CriteriaState : public BranchState {
  public:
    explicit CriteriaState(const EvaluatorBank& bank) : bank_(&bank), buffer_(bank.bufferSize()) {
        bank.reset(buffer_.data());
    }
    std::unique_ptr<BranchState> clone() const override {
        return std::make_unique<CriteriaState>(*this);
    }
    bool push(const PathEvent& e) override {
        // A true criterion stays true, so the branch is wanted whatever follows: the
        // evaluators are not needed any more, and dropping them makes later clones cheap.
        if (wanted_) return true;
        thread_local StreamingEvaluator::Scratch scratch;
        bool any = false;
        for (size_t c = 0; c < bank_->size(); ++c) {
            if (bank_->state(c, buffer_.data()) == CriterionState::False) continue;
            const CriterionState s = bank_->push(c, buffer_.data(), e, scratch);
            if (s == CriterionState::True) {
                wanted_ = true;
                buffer_ = {};
                return true;
            }
            if (s != CriterionState::False) any = true;
        }
        return any;
    }

  private:
    const EvaluatorBank* bank_;
    std::vector<std::byte> buffer_;  // the state of every criterion's evaluator
    bool wanted_ = false;            // some criterion is already true
};

}  // namespace

std::unique_ptr<BranchState> CriteriaFilter::start() const {
    return std::make_unique<CriteriaState>(bank_);
}

}  // namespace veil
