#pragma once
// Ray path pictures: the first N emitted rays with a path that satisfies a criterion, each
// drawn with every one of its branches that does, over the 2D layout (the seed's figures
// 1a/1b and 4-6: "the first 1000 rays").
//
//   criterion text ──selectPaths(TransportView)──> PathSelection ──drawPaths(layout)──> Picture
//
// Selection traces rays in batches with path histories and evaluates the criterion on every
// complete path (root to leaf) of every ray. It keeps the first `count` rays with a match in
// ray index order, each with its matching paths in leaf order, so the result is the same
// whatever the thread count: the rays of a batch finish in any order, but only the lowest
// indices are kept. In split mode one ray is a tree of branches (hundreds on a scene with
// scattering mounts); a kept ray stores the nodes of its matching paths once, as a tree.
//
// Batch b traces with seed `seed + b`; ray r of batch b has the global index
// b * batchRays * sources + r (batch 0 is exactly `veil trace --seed seed`).

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "analysis/criteria/criteria.h"
#include "analysis/pictures/picture.h"
#include "analysis/reports/progress.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

// One complete path, root (the emission) to leaf. Node k > 0 ends the segment that starts at
// node k-1: segment k runs from points[k-1] to points[k], carries flux[k] and ends with
// events[k].type. Node 0 is the emission (flux[0] = emitted flux).
struct SelectedPath {
    uint64_t ray = 0;  // global ray index (see the header comment)
    NodeIndex leaf = kNoNode;
    std::vector<Vec3> points;       // global, mm
    std::vector<double> flux;       // arriving at each node (W or lm, as the sources)
    std::vector<PathEvent> events;  // what the criterion saw, in path order
    size_t segmentCount() const { return points.empty() ? 0 : points.size() - 1; }
};
std::ostream& operator<<(std::ostream& os, const SelectedPath& p);

// One emitted ray with at least one matching path: the nodes of its matching paths, each
// once, parents before children (node 0 is the emission), and the matching leaves.
struct SelectedRay {
    uint64_t ray = 0;                  // global ray index (see the header comment)
    std::vector<Vec3> points;          // global, mm
    std::vector<double> flux;          // arriving at each node
    std::vector<PathEvent> events;     // the event at each node, as the criterion saw it
    std::vector<int> parent;           // -1 for the emission
    std::vector<int> leaves;           // matching paths' last nodes, in leaf order
    std::vector<NodeIndex> leafNodes;  // the same leaves as nodes of the ray's PathHistory
    // The k-th matching path, root to leaf.
    SelectedPath path(size_t k) const;
};

struct PathSelectionOptions {
    std::string where;           // criterion text (docs/criteria.md)
    size_t count = 300;          // emitted rays (with a matching path) to keep
    uint64_t maxRays = 1000000;  // emitted rays (all sources) to trace at most
    uint64_t batchRays = 20000;  // rays per source per batch
    TransportOptions transport;  // recordHistories is forced on; seed is the base seed
    // How errors in `where` name it ("--where": "--where:1:13").
    std::string whereSource = "--where";
    // After each batch: the emitted rays traced so far (all sources) of maxRays, as `task`
    // events; may be empty. A selection that finds its rays early ends before maxRays.
    ProgressSink progress;
    std::string task = "paths";
};

struct PathSelection {
    std::string criterion;          // the text as given
    std::vector<SelectedRay> rays;  // the first `count` rays with a match, by ray index
    uint64_t raysTraced = 0;        // emitted rays (all sources)
    uint64_t pathsEvaluated = 0;    // complete paths seen
    uint64_t pathsMatched = 0;      // of those, matching (can exceed pathCount())
    std::string fluxUnit = "W";     // of the flux: the (first) source's, W or lm
    size_t requested = 0;           // rays asked for
    bool complete() const { return !rays.empty() && rays.size() >= requested; }
    // Matching paths of the kept rays, and all of them in (ray, leaf) order.
    size_t pathCount() const;
    std::vector<SelectedPath> paths() const;
};
std::ostream& operator<<(std::ostream& os, const PathSelection& s);

// Parses and compiles options.where against the scene's names (ParseError with the column on
// a bad criterion), then traces batches until `count` rays with a match are found or maxRays
// are traced.
// `detectors` are the empty images traceNonsequential needs (SceneTransport::images).
PathSelection selectPaths(const TransportView& ts, const std::vector<DetectorImage>& detectors,
                          const PathSelectionOptions& options);

// Path Pictures
enum class PathColouring { LogFlux, EventType };
std::ostream& operator<<(std::ostream& os, PathColouring c);

struct PathPictureOptions {
    PathColouring colouring = PathColouring::LogFlux;
    double decades = 6.0;  // LogFlux: the colour ramp spans [max 10^-decades, max]
    double lineWidthPt = 0.5;
    // Segments are clipped to this y-z rectangle (mm): {zMin, zMax, yMin, yMax}; unset, to
    // the base picture's frame. Exit segments run to the scene's far bounds.
    std::optional<std::array<double, 4>> clipZY;
};

// The colour of a segment ending with event `t` in the EventType palette: refract blue,
// Fresnel and specular reflection red, TIR orange, scatter green, absorb and exit grey,
// detector black.
Color eventColour(EventType t);
// The event key of the EventType palette, in legend order: label and an event of each colour.
const std::vector<std::pair<const char*, EventType>>& eventLegend();

// The largest flux a kept segment carries (0 without segments).
double maxSegmentFlux(const PathSelection& selection);
// The LogFlux colour of a segment: log10(flux / maxFlux) over `decades` decades on the
// false-colour ramp, its lowest colour for nothing (flux or maxFlux <= 0).
Color segmentFluxColour(double flux, double maxFlux, double decades);

// `base` (from drawLayout) with the segments of every kept ray's matching paths (each segment
// once) projected to the y-z plane (a point (x, y, z) is drawn at (z, y)) and a legend: the
// criterion, the numbers of rays and paths and the colour key.
//
// LogFlux colours a segment by the flux the traced ray (or its split branch) carries along
// it, in the sources' unit (W or lm): absolute, per traced ray, so it scales with 1 / the
// rays per source of the batch. The colour is log10(flux / brightest segment drawn) over
// `decades` decades (the brightest is usually a ray as emitted); the key shows that range
// as the colour bar with its two ends in W or lm.
Picture drawPaths(const Picture& base, const PathSelection& selection,
                  const PathPictureOptions& options = {});

}  // namespace veil
