#pragma once
// Ray path histories: everything that happened to one emitted ray and to every branch split
// from it, as the seed's section 2.1 asks (emission, the linear segments with their flux and
// colour, the event at the end of each segment with its object, absorption, leaving the
// scene, detector hits).
//
// One PathHistory holds one emitted ray. It is a tree in a per-ray arena: node 0 is the
// emission, every later node is an event with a link to its parent node, and splitting at a
// Fresnel interface appends two children (Refract and FresnelReflect) to the same parent, so
// the branches share their prefix instead of copying it. Every leaf is the end of one complete
// path; the path is the chain of nodes from the root to that leaf.
//
//      0 Emit ── 1 Refract L1.front ─┬─ 2 Refract L1.back ── 4 DetectorHit sensor
//                                    └─ 3 FresnelReflect L1.back ── 5 Exit
//                      leaves 4 and 5: paths 0-1-2-4 and 0-1-3-5
//
// A node records the event and the state of the ray at it:
//   position   where the event happened (global, mm); Emit: the emission point
//   direction  unit direction of the ray leaving the event; for events that end the ray
//              (absorption, exit, cull) the direction it arrived with
//   flux       the flux ARRIVING at the event, carried by the segment that ends there
//              (W or lm, as the run's sources); Emit: the emitted flux
//   medium     index of the medium the ray is in AFTER the event (Scene::media()); the medium
//              before is the parent's. Refract: the medium entered; reflections: unchanged
//   object     the scene object id of the event, -1 if none (Exit, VolumeAbsorb, Culled in
//              the open). Emit: the SOURCE index (sources are not scene objects), so a
//              criterion "emitted by source S" tests the first event like any other
//   face       triangle index within the object's mesh; 0 for exact faces
//   detail     ScatterReflect/ScatterTransmit: the scatter model index of the property;
//              Culled: a CullReason; otherwise 0
// The segment that ends at node k starts at its parent's position, runs along the parent's
// direction through the parent's medium and carries node k's flux.
//
// The compact byte encoding (encodeHistory/decodeHistory) is documented byte by byte in
// docs/ray-database.md: 2 to 4 bytes for an event that keeps its parent's flux, 6 to 8 for one
// that changes it (6.5 on average on lens-like histories), plus 12 or 24 bytes of geometry.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <ostream>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "geometry/vec.h"

namespace veil {

// Path History Event Types
// The numeric values are the file format (4 bits in docs/ray-database.md): never renumber.
enum class EventType : uint8_t {
    Emit = 0,                     // the ray leaves its source
    Refract = 1,                  // transmitted through an interface (specular)
    SpecularReflect = 2,          // mirror or coated reflection
    FresnelReflect = 3,           // ghost: the reflected branch at a refracting interface
    TotalInternalReflection = 4,  // beyond the critical angle: all flux reflected
    ScatterReflect = 5,           // diffuse or lobe scatter back into the incident medium
    ScatterTransmit = 6,          // diffuse or lobe scatter through the surface
    SurfaceAbsorb = 7,            // absorbed at a surface (black paint, absorber)
    VolumeAbsorb = 8,             // absorbed inside a medium (internal transmittance)
    Exit = 9,                     // leaves the scene
    DetectorHit = 10,             // recorded by a detector (the object is the detector)
    Culled = 11,                  // stopped by the tracer; the reason is in the node's detail
};
inline constexpr int kEventTypeCount = 12;
// "emit", "refract", "specular_reflect", "fresnel_reflect", "tir", "scatter_reflect",
// "scatter_transmit", "surface_absorb", "volume_absorb", "exit", "detector_hit", "culled".
std::string_view toString(EventType t);
std::optional<EventType> eventTypeFromString(std::string_view name);
std::ostream& operator<<(std::ostream& os, EventType t);
// Events after which the ray cannot go on: absorption, exit, cull.
constexpr bool isTerminal(EventType t) {
    return t == EventType::SurfaceAbsorb || t == EventType::VolumeAbsorb || t == EventType::Exit ||
           t == EventType::Culled;
}
// Events whose node detail byte is meaningful (and stored in the encoding).
constexpr bool hasDetail(EventType t) {
    return t == EventType::ScatterReflect || t == EventType::ScatterTransmit ||
           t == EventType::Culled;
}

// Why the tracer stopped a branch (the detail of a Culled event). Values are file format.
enum class CullReason : uint8_t {
    RussianRoulette = 0,
    MinFlux = 1,        // split branch below the minimum relative flux
    MaxSegments = 2,    // segment limit per branch
    MaxSplitDepth = 3,  // too many splits on the path
    Criterion = 4,      // online pruning: the path criterion became false
};
std::string_view toString(CullReason r);
std::ostream& operator<<(std::ostream& os, CullReason r);

// One event as the criteria evaluator consumes it (analysis/criteria), in path order.
struct PathEvent {
    EventType type = EventType::Emit;
    int32_t object = -1;  // scene object id; Emit: source index; -1: none
    int32_t face = 0;     // triangle within the object's mesh, 0 for exact faces
    int16_t mediumBefore = 0;
    int16_t mediumAfter = 0;
    float flux = 0.0f;  // flux arriving at the event (Emit: emitted)

    bool operator==(const PathEvent&) const = default;
};
std::ostream& operator<<(std::ostream& os, const PathEvent& e);

// One straight piece of a path and the event at its end (for pictures and detectors). The
// Emit event ends a zero-length segment at the emission point.
struct Segment {
    Vec3 start{0.0}, end{0.0};  // global, mm
    Vec3 direction{0.0};        // unit
    double flux = 0.0;          // carried along the segment, arriving at its end
    float wavelengthNm = 0.0f;
    int16_t medium = 0;  // the medium the segment runs in
    EventType event = EventType::Emit;
    int32_t object = -1;
    int32_t face = 0;
    uint8_t scatterModel = 0;  // scatter events: model index; else 0
};
std::ostream& operator<<(std::ostream& os, const Segment& s);

using NodeIndex = int32_t;
inline constexpr NodeIndex kNoNode = -1;

// One node of the tree: an event and the ray's state at it (see the header comment).
struct PathNode {
    Vec3 position{0.0};
    Vec3 direction{0.0};
    double flux = 0.0;
    NodeIndex parent = kNoNode;
    int32_t object = -1;
    int32_t face = 0;
    int16_t medium = 0;
    EventType type = EventType::Emit;
    uint8_t detail = 0;
    bool hasChildren = false;  // maintained by PathHistory::append

    bool operator==(const PathNode&) const = default;
};
std::ostream& operator<<(std::ostream& os, const PathNode& n);

class PathView;
struct PathEncoding;

// Path History Class
// Built by the tracer one event at a time (append is a push_back into a reused vector), read
// by detectors, criteria, pictures and the ray database.
class PathHistory {
  public:
    PathHistory() = default;

    // Starts a new ray, keeping the allocated capacity: the tracer reuses one history per
    // thread. Returns the root node (0), the Emit event of source `source`.
    NodeIndex start(int32_t source, float wavelengthNm, const Vec3& position, const Vec3& direction,
                    double flux, int16_t medium);
    // Appends an event after `parent` (any existing node: appending two children to one node
    // is a split). node.parent is overwritten; node.hasChildren is ignored. Returns the new
    // node's index. Throws std::invalid_argument for a bad parent, an Emit event or face < 0.
    NodeIndex append(NodeIndex parent, const PathNode& node);
    void clear();

    int32_t source() const { return nodes_.empty() ? -1 : nodes_[0].object; }
    float wavelengthNm() const { return wavelengthNm_; }
    bool empty() const { return nodes_.empty(); }
    size_t size() const { return nodes_.size(); }  // events, the Emit included
    const PathNode& node(NodeIndex i) const { return nodes_[static_cast<size_t>(i)]; }
    std::span<const PathNode> nodes() const { return nodes_; }

    // The event at node i, its medium before taken from the parent.
    PathEvent event(NodeIndex i) const;
    // The segment ending at node i.
    Segment segment(NodeIndex i) const;
    // Leaves in increasing node order: one per complete path.
    bool isLeaf(NodeIndex i) const { return !node(i).hasChildren; }
    size_t pathCount() const;
    // The root-to-leaf node chain of `leaf` into `scratch` (reused) and a view on it.
    PathView path(NodeIndex leaf, std::vector<NodeIndex>& scratch) const;
    // Calls f(const PathView&) for every complete path, leaves in increasing node order.
    template <class F>
    void forEachPath(F&& f) const;

    // Whether positions and directions are known: true for histories built by the tracer,
    // false for ones read from a database that did not store them (they read as zero).
    bool hasPositions() const { return hasPositions_; }
    bool hasDirections() const { return hasDirections_; }

    bool operator==(const PathHistory& o) const = default;

  private:
    friend void decodeHistory(std::span<const uint8_t>, size_t&, const PathEncoding&, PathHistory&);

    std::vector<PathNode> nodes_;
    float wavelengthNm_ = 0.0f;
    bool hasPositions_ = true;
    bool hasDirections_ = true;
};
std::ostream& operator<<(std::ostream& os, const PathHistory& h);

// One complete path: a history and the node chain from its root to a leaf. Cheap to copy; it
// refers to both, which must outlive it.
class PathView {
  public:
    PathView(const PathHistory& history, std::span<const NodeIndex> nodes)
        : history_(&history), nodes_(nodes) {}

    size_t size() const { return nodes_.size(); }
    NodeIndex node(size_t i) const { return nodes_[i]; }
    NodeIndex leaf() const { return nodes_.back(); }
    PathEvent event(size_t i) const { return history_->event(nodes_[i]); }
    Segment segment(size_t i) const { return history_->segment(nodes_[i]); }
    const PathHistory& history() const { return *history_; }

    // Range over the events in path order: for (PathEvent e : view) ...
    class Iterator {
      public:
        using value_type = PathEvent;
        using difference_type = std::ptrdiff_t;
        Iterator() = default;
        Iterator(const PathView* v, size_t i) : view_(v), i_(i) {}
        PathEvent operator*() const { return view_->event(i_); }
        Iterator& operator++() {
            ++i_;
            return *this;
        }
        Iterator operator++(int) {
            Iterator old = *this;
            ++i_;
            return old;
        }
        bool operator==(const Iterator& o) const { return i_ == o.i_; }

      private:
        const PathView* view_ = nullptr;
        size_t i_ = 0;
    };
    Iterator begin() const { return {this, 0}; }
    Iterator end() const { return {this, nodes_.size()}; }

  private:
    const PathHistory* history_;
    std::span<const NodeIndex> nodes_;
};
std::ostream& operator<<(std::ostream& os, const PathView& p);

template <class F>
void PathHistory::forEachPath(F&& f) const {
    std::vector<NodeIndex> scratch;
    for (NodeIndex i = 0; i < static_cast<NodeIndex>(nodes_.size()); ++i) {
        if (!nodes_[static_cast<size_t>(i)].hasChildren) f(path(i, scratch));
    }
}

// Path History Encoding
// What encodeHistory stores besides the events (the ray database header's flags).
struct PathEncoding {
    bool positions = false;        // event positions
    bool directions = false;       // outgoing directions
    bool doublePrecision = false;  // flux, positions and directions as float64, else float32

    bool operator==(const PathEncoding&) const = default;
};
std::ostream& operator<<(std::ostream& os, const PathEncoding& e);

// A byte string that is not a valid history; offset counts from the start of the span given
// to decodeHistory.
class PathDecodeError : public std::runtime_error {
  public:
    PathDecodeError(size_t offset, const std::string& message);
    size_t offset() const { return offset_; }
    const std::string& message() const { return message_; }

  private:
    size_t offset_;
    std::string message_;
};

// Appends the encoding of `h` to `out` (the layout is in docs/ray-database.md). Values are
// rounded to float32 unless doublePrecision; ids, types, media and the tree are exact.
// Throws std::invalid_argument for a history that cannot be encoded (empty, more than 2^31
// nodes, medium out of int16).
void encodeHistory(const PathHistory& h, const PathEncoding& enc, std::vector<uint8_t>& out);
// Decodes one history from bytes[pos...] into `out` (its capacity is reused) and advances
// pos past it. Throws PathDecodeError with the offset of the offending byte.
void decodeHistory(std::span<const uint8_t> bytes, size_t& pos, const PathEncoding& enc,
                   PathHistory& out);

// Little-endian base-128 varints (LEB128) and zigzag, shared with the ray database.
void putVarint(std::vector<uint8_t>& out, uint64_t v);
// Reads a varint of at most 10 bytes at bytes[pos], advancing pos; throws PathDecodeError if
// it runs past the end or overflows 64 bits.
uint64_t getVarint(std::span<const uint8_t> bytes, size_t& pos);
constexpr uint64_t zigzag(int64_t v) {
    return (static_cast<uint64_t>(v) << 1) ^ static_cast<uint64_t>(v >> 63);
}
constexpr int64_t unzigzag(uint64_t v) {
    return static_cast<int64_t>(v >> 1) ^ -static_cast<int64_t>(v & 1);
}

}  // namespace veil
