#include "tracer/records/path_history.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>

namespace veil {

// Event Names

namespace {

constexpr std::array<std::string_view, kEventTypeCount> kEventNames = {
    "emit",
    "refract",
    "specular_reflect",
    "fresnel_reflect",
    "tir",
    "scatter_reflect",
    "scatter_transmit",
    "surface_absorb",
    "volume_absorb",
    "exit",
    "detector_hit",
    "culled",
};

}  // namespace

std::string_view toString(EventType t) {
    const auto i = static_cast<size_t>(t);
    return i < kEventNames.size() ? kEventNames[i] : std::string_view("invalid");
}

std::optional<EventType> eventTypeFromString(std::string_view name) {
    for (size_t i = 0; i < kEventNames.size(); ++i) {
        if (kEventNames[i] == name) return static_cast<EventType>(i);
    }
    return std::nullopt;
}

std::ostream& operator<<(std::ostream& os, EventType t) { return os << toString(t); }

std::string_view toString(CullReason r) {
    switch (r) {
        case CullReason::RussianRoulette:
            return "russian_roulette";
        case CullReason::MinFlux:
            return "min_flux";
        case CullReason::MaxSegments:
            return "max_segments";
        case CullReason::MaxSplitDepth:
            return "max_split_depth";
        case CullReason::Criterion:
            return "criterion";
    }
    return "invalid";
}

std::ostream& operator<<(std::ostream& os, CullReason r) { return os << toString(r); }

std::ostream& operator<<(std::ostream& os, const PathEvent& e) {
    os << e.type << "{object " << e.object;
    if (e.face != 0) os << ", face " << e.face;
    os << ", medium " << e.mediumBefore;
    if (e.mediumAfter != e.mediumBefore) os << "->" << e.mediumAfter;
    return os << ", flux " << e.flux << "}";
}

std::ostream& operator<<(std::ostream& os, const Segment& s) {
    os << "Segment{" << s.start << " -> " << s.end << ", dir " << s.direction << ", flux " << s.flux
       << ", " << s.wavelengthNm << " nm, medium " << s.medium << ", ends in " << s.event
       << " at object " << s.object;
    if (s.face != 0) os << " face " << s.face;
    if (s.scatterModel != 0) os << " model " << int(s.scatterModel);
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const PathNode& n) {
    os << n.type << " parent " << n.parent << " object " << n.object;
    if (n.face != 0) os << " face " << n.face;
    os << " medium " << n.medium << " flux " << n.flux << " at " << n.position << " dir "
       << n.direction;
    if (n.type == EventType::Culled) {
        os << " (" << static_cast<CullReason>(n.detail) << ")";
    } else if (hasDetail(n.type)) {
        os << " (model " << int(n.detail) << ")";
    }
    return os;
}

// Path History Building

NodeIndex PathHistory::start(int32_t source, float wavelengthNm, const Vec3& position,
                             const Vec3& direction, double flux, int16_t medium) {
    if (source < 0) throw std::invalid_argument("PathHistory::start: source < 0");
    if (medium < 0) throw std::invalid_argument("PathHistory::start: medium < 0");
    nodes_.clear();
    wavelengthNm_ = wavelengthNm;
    hasPositions_ = hasDirections_ = true;
    PathNode root;
    root.position = position;
    root.direction = direction;
    root.flux = flux;
    root.object = source;
    root.medium = medium;
    root.type = EventType::Emit;
    nodes_.push_back(root);
    return 0;
}

NodeIndex PathHistory::append(NodeIndex parent, const PathNode& node) {
    if (parent < 0 || static_cast<size_t>(parent) >= nodes_.size()) {
        throw std::invalid_argument("PathHistory::append: parent " + std::to_string(parent) +
                                    " is not a node (history has " + std::to_string(nodes_.size()) +
                                    ")");
    }
    if (node.type == EventType::Emit || static_cast<int>(node.type) >= kEventTypeCount) {
        throw std::invalid_argument("PathHistory::append: event type must be a non-Emit event");
    }
    if (node.face < 0 || node.object < -1 || node.medium < 0) {
        throw std::invalid_argument("PathHistory::append: face < 0, object < -1 or medium < 0");
    }
    if (nodes_.size() >= static_cast<size_t>(std::numeric_limits<NodeIndex>::max())) {
        throw std::invalid_argument("PathHistory::append: more than 2^31 - 1 events");
    }
    nodes_[static_cast<size_t>(parent)].hasChildren = true;
    nodes_.push_back(node);
    PathNode& n = nodes_.back();
    n.parent = parent;
    n.hasChildren = false;
    return static_cast<NodeIndex>(nodes_.size() - 1);
}

void PathHistory::clear() {
    nodes_.clear();
    wavelengthNm_ = 0.0f;
    hasPositions_ = hasDirections_ = true;
}

// Path History Reading

PathEvent PathHistory::event(NodeIndex i) const {
    const PathNode& n = node(i);
    PathEvent e;
    e.type = n.type;
    e.object = n.object;
    e.face = n.face;
    e.mediumAfter = n.medium;
    e.mediumBefore = n.parent == kNoNode ? n.medium : node(n.parent).medium;
    e.flux = static_cast<float>(n.flux);
    return e;
}

Segment PathHistory::segment(NodeIndex i) const {
    const PathNode& n = node(i);
    const PathNode& from = n.parent == kNoNode ? n : node(n.parent);
    Segment s;
    s.start = from.position;
    s.end = n.position;
    s.direction = from.direction;
    s.flux = n.flux;
    s.wavelengthNm = wavelengthNm_;
    s.medium = from.medium;
    s.event = n.type;
    s.object = n.object;
    s.face = n.face;
    s.scatterModel = (n.type == EventType::ScatterReflect || n.type == EventType::ScatterTransmit)
                         ? n.detail
                         : uint8_t{0};
    return s;
}

size_t PathHistory::pathCount() const {
    return static_cast<size_t>(std::count_if(nodes_.begin(), nodes_.end(),
                                             [](const PathNode& n) { return !n.hasChildren; }));
}

PathView PathHistory::path(NodeIndex leaf, std::vector<NodeIndex>& scratch) const {
    scratch.clear();
    for (NodeIndex i = leaf; i != kNoNode; i = node(i).parent) scratch.push_back(i);
    std::reverse(scratch.begin(), scratch.end());
    return PathView(*this, scratch);
}

std::ostream& operator<<(std::ostream& os, const PathHistory& h) {
    os << "PathHistory{source " << h.source() << ", " << h.wavelengthNm() << " nm, " << h.size()
       << " events, " << h.pathCount() << " paths}";
    for (size_t i = 0; i < h.size(); ++i) os << "\n  [" << i << "] " << h.nodes()[i];
    return os;
}

std::ostream& operator<<(std::ostream& os, const PathView& p) {
    os << "Path{";
    for (size_t i = 0; i < p.size(); ++i) os << (i ? ", " : "") << p.event(i);
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const PathEncoding& e) {
    return os << "PathEncoding{positions " << e.positions << ", directions " << e.directions << ", "
              << (e.doublePrecision ? "float64" : "float32") << "}";
}

// Path History Encoding
// Layout (docs/ray-database.md, "History"): wavelength f32, varint node count, then per node
//   tag u8: bits 0-3 type, bit 4 F face != 0, bit 5 M medium changes, bit 6 S flux equals the
//           parent's (as stored), bit 7 P parent is not the previous node
//   [P] varint (index - 1 - parent)     object varint (object + 1)
//   [F] varint face                     [M] zigzag varint (medium - parent's medium)
//   [detail u8 for scatter and cull]    [!S] flux    [positions] x y z    [directions] x y z

namespace {

constexpr uint8_t kTagFace = 1u << 4;
constexpr uint8_t kTagMedium = 1u << 5;
constexpr uint8_t kTagSameFlux = 1u << 6;
constexpr uint8_t kTagParent = 1u << 7;

void putU32(std::vector<uint8_t>& out, uint32_t v) {
    const uint8_t b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
    out.insert(out.end(), b, b + 4);
}

void putU64(std::vector<uint8_t>& out, uint64_t v) {
    uint8_t b[8];
    for (int i = 0; i < 8; ++i) b[i] = uint8_t(v >> (8 * i));
    out.insert(out.end(), b, b + 8);
}

// A real number in the stored precision, and its bit pattern for exact comparison.
struct Real {
    bool wide;
    uint64_t bits(double v) const {
        return wide ? std::bit_cast<uint64_t>(v) : std::bit_cast<uint32_t>(static_cast<float>(v));
    }
    void put(std::vector<uint8_t>& out, double v) const {
        if (wide) {
            putU64(out, std::bit_cast<uint64_t>(v));
        } else {
            putU32(out, std::bit_cast<uint32_t>(static_cast<float>(v)));
        }
    }
};

class Cursor {
  public:
    Cursor(std::span<const uint8_t> b, size_t& pos) : b_(b), pos_(pos) {}
    void need(size_t n, const char* what) const {
        if (pos_ > b_.size() || b_.size() - pos_ < n) {
            throw PathDecodeError(pos_, std::string("unexpected end of data in ") + what);
        }
    }
    uint8_t u8(const char* what) {
        need(1, what);
        return b_[pos_++];
    }
    uint32_t u32(const char* what) {
        need(4, what);
        uint32_t v = 0;
        for (int i = 0; i < 4; ++i) v |= uint32_t(b_[pos_ + i]) << (8 * i);
        pos_ += 4;
        return v;
    }
    uint64_t u64(const char* what) {
        need(8, what);
        uint64_t v = 0;
        for (int i = 0; i < 8; ++i) v |= uint64_t(b_[pos_ + i]) << (8 * i);
        pos_ += 8;
        return v;
    }
    double real(bool wide, const char* what) {
        return wide ? std::bit_cast<double>(u64(what))
                    : static_cast<double>(std::bit_cast<float>(u32(what)));
    }
    uint64_t varint() { return getVarint(b_, pos_); }
    size_t pos() const { return pos_; }
    size_t remaining() const { return b_.size() - pos_; }

  private:
    std::span<const uint8_t> b_;
    size_t& pos_;
};

}  // namespace

PathDecodeError::PathDecodeError(size_t offset, const std::string& message)
    : std::runtime_error("byte " + std::to_string(offset) + ": " + message),
      offset_(offset),
      message_(message) {}

void putVarint(std::vector<uint8_t>& out, uint64_t v) {
    while (v >= 0x80) {
        out.push_back(static_cast<uint8_t>(v | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<uint8_t>(v));
}

uint64_t getVarint(std::span<const uint8_t> bytes, size_t& pos) {
    const size_t start = pos;
    uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
        if (pos >= bytes.size()) throw PathDecodeError(pos, "unexpected end of data in a varint");
        const uint8_t b = bytes[pos++];
        if (shift == 63 && b > 1) throw PathDecodeError(start, "varint overflows 64 bits");
        v |= uint64_t(b & 0x7f) << shift;
        if (!(b & 0x80)) return v;
    }
    throw PathDecodeError(start, "varint longer than 10 bytes");
}

void encodeHistory(const PathHistory& h, const PathEncoding& enc, std::vector<uint8_t>& out) {
    if (h.empty()) throw std::invalid_argument("encodeHistory: empty history (no Emit event)");
    const Real real{enc.doublePrecision};
    putU32(out, std::bit_cast<uint32_t>(h.wavelengthNm()));
    putVarint(out, h.size());
    const std::span<const PathNode> nodes = h.nodes();
    for (size_t i = 0; i < nodes.size(); ++i) {
        const PathNode& n = nodes[i];
        const int64_t expectedParent = static_cast<int64_t>(i) - 1;
        const bool root = i == 0;
        const int parentMedium = root ? 0 : nodes[static_cast<size_t>(n.parent)].medium;
        const bool sameFlux =
            !root && real.bits(n.flux) == real.bits(nodes[static_cast<size_t>(n.parent)].flux);
        uint8_t tag = static_cast<uint8_t>(n.type);
        if (n.face != 0) tag |= kTagFace;
        if (n.medium != parentMedium) tag |= kTagMedium;
        if (sameFlux) tag |= kTagSameFlux;
        if (n.parent != expectedParent) tag |= kTagParent;
        out.push_back(tag);
        if (tag & kTagParent) putVarint(out, static_cast<uint64_t>(expectedParent - n.parent));
        putVarint(out, static_cast<uint64_t>(int64_t{n.object} + 1));
        if (tag & kTagFace) putVarint(out, static_cast<uint64_t>(n.face));
        if (tag & kTagMedium) putVarint(out, zigzag(int64_t{n.medium} - parentMedium));
        if (hasDetail(n.type)) out.push_back(n.detail);
        if (!sameFlux) real.put(out, n.flux);
        if (enc.positions) {
            for (int k = 0; k < 3; ++k) real.put(out, n.position[k]);
        }
        if (enc.directions) {
            for (int k = 0; k < 3; ++k) real.put(out, n.direction[k]);
        }
    }
}

void decodeHistory(std::span<const uint8_t> bytes, size_t& pos, const PathEncoding& enc,
                   PathHistory& out) {
    Cursor in(bytes, pos);
    out.nodes_.clear();
    out.hasPositions_ = enc.positions;
    out.hasDirections_ = enc.directions;
    out.wavelengthNm_ = std::bit_cast<float>(in.u32("the wavelength"));
    const size_t countAt = in.pos();
    const uint64_t count = in.varint();
    // Every node takes at least two bytes (tag, object): a larger count is corrupt, and
    // checking it first keeps a corrupt count from allocating gigabytes.
    if (count == 0 || count > in.remaining() / 2 ||
        count > static_cast<uint64_t>(std::numeric_limits<NodeIndex>::max())) {
        throw PathDecodeError(countAt, "invalid event count " + std::to_string(count) + " (" +
                                           std::to_string(in.remaining()) + " bytes left)");
    }
    out.nodes_.resize(count);
    for (uint64_t i = 0; i < count; ++i) {
        const size_t tagAt = in.pos();
        const uint8_t tag = in.u8("an event tag");
        const int typeValue = tag & 0x0f;
        if (typeValue >= kEventTypeCount) {
            throw PathDecodeError(tagAt, "invalid event type " + std::to_string(typeValue));
        }
        PathNode& n = out.nodes_[i];
        n.type = static_cast<EventType>(typeValue);
        if ((i == 0) != (n.type == EventType::Emit)) {
            throw PathDecodeError(tagAt, i == 0 ? "the first event is not an emission"
                                                : "emission after the first event");
        }
        int64_t parent = static_cast<int64_t>(i) - 1;
        if (tag & kTagParent) {
            const size_t at = in.pos();
            const uint64_t d = in.varint();
            if (i == 0 || d == 0 || d > i - 1) {
                throw PathDecodeError(at, "invalid parent distance " + std::to_string(d) +
                                              " at event " + std::to_string(i));
            }
            parent -= static_cast<int64_t>(d);
        }
        n.parent = static_cast<NodeIndex>(parent);
        n.hasChildren = false;
        const size_t objectAt = in.pos();
        const uint64_t object = in.varint();
        if (object > static_cast<uint64_t>(std::numeric_limits<int32_t>::max())) {
            throw PathDecodeError(objectAt, "object id out of range");
        }
        n.object = static_cast<int32_t>(object) - 1;
        if (i == 0 && n.object < 0) throw PathDecodeError(objectAt, "emission without a source");
        n.face = 0;
        if (tag & kTagFace) {
            const size_t at = in.pos();
            const uint64_t face = in.varint();
            if (face == 0 || face > static_cast<uint64_t>(std::numeric_limits<int32_t>::max())) {
                throw PathDecodeError(at, "face index out of range");
            }
            n.face = static_cast<int32_t>(face);
        }
        const PathNode* p = parent >= 0 ? &out.nodes_[static_cast<size_t>(parent)] : nullptr;
        int64_t medium = p ? p->medium : 0;
        if (tag & kTagMedium) {
            const size_t at = in.pos();
            const int64_t delta = unzigzag(in.varint());
            medium += delta;
            if (delta == 0 || medium < 0 || medium > std::numeric_limits<int16_t>::max()) {
                throw PathDecodeError(at, "medium out of range");
            }
        }
        n.medium = static_cast<int16_t>(medium);
        n.detail = hasDetail(n.type) ? in.u8("an event detail") : uint8_t{0};
        if (tag & kTagSameFlux) {
            if (!p) throw PathDecodeError(tagAt, "the emission has no parent flux to repeat");
            n.flux = p->flux;
        } else {
            n.flux = in.real(enc.doublePrecision, "a flux");
        }
        n.position = Vec3(0.0);
        n.direction = Vec3(0.0);
        if (enc.positions) {
            for (int k = 0; k < 3; ++k) n.position[k] = in.real(enc.doublePrecision, "a position");
        }
        if (enc.directions) {
            for (int k = 0; k < 3; ++k) {
                n.direction[k] = in.real(enc.doublePrecision, "a direction");
            }
        }
        if (p) out.nodes_[static_cast<size_t>(parent)].hasChildren = true;
    }
}

}  // namespace veil
