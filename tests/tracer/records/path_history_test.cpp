// Path histories: the tree of one emitted ray (splitting shares prefixes), the events and
// segments of its complete paths, and the compact byte encoding, checked by exact round
// trips of random split trees (fixed seeds) and a measured bytes-per-event bound.

#include "tracer/records/path_history.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <iostream>
#include <sstream>

#include "tracer/runtime/rng.h"

namespace veil {

// Random Histories (shared with ray_database_test.cpp)
// A ray through a lens-like scene: objects 0-23 are lens faces, 24-39 mechanics with up to
// 5000 triangles, 40 the detector; media 0 (air) and 1-6 (glasses). Fresnel interfaces split
// into a refracted and a reflected branch, as the tracer's default mode does. Half of the
// refractions are lossless (ideal AR), so the "same flux" flag gets exercised.
PathHistory randomHistory(uint64_t seed, uint64_t ray, int maxEvents) {
    CounterRng rng(seed, ray);
    auto pick = [&](int n) { return static_cast<int>(rng.uniform() * n); };
    auto unit = [&] {
        for (;;) {
            const Vec3 v(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1);
            const double l = glm::length(v);
            if (l > 1e-3 && l <= 1.0) return v / l;
        }
    };
    auto point = [&] {
        return Vec3(80 * (rng.uniform() - 0.5), 80 * (rng.uniform() - 0.5), 360 * rng.uniform());
    };
    static constexpr float kWavelengths[3] = {486.13f, 587.56f, 656.27f};
    PathHistory h;
    h.start(pick(3), kWavelengths[pick(3)], point(), unit(), 1e-3 * (0.5 + rng.uniform()), 0);
    struct Branch {
        NodeIndex node;
        double flux;  // leaving the node
        int depth;
    };
    std::vector<Branch> stack{{0, h.node(0).flux, 0}};
    auto toggle = [&](int16_t medium) {
        return static_cast<int16_t>(medium == 0 ? 1 + pick(6) : 0);
    };
    while (!stack.empty()) {
        const Branch b = stack.back();
        stack.pop_back();
        const int16_t medium = h.node(b.node).medium;
        PathNode n;
        n.position = point();
        n.direction = unit();
        n.flux = b.flux * ((medium != 0 && pick(2)) ? 0.998 : 1.0);
        n.medium = medium;
        if (static_cast<int>(h.size()) + 2 >= maxEvents || b.depth >= 40) {
            n.type = EventType::Culled;
            n.detail = static_cast<uint8_t>(CullReason::MaxSegments);
            h.append(b.node, n);
            continue;
        }
        const double u = rng.uniform();
        if (u < 0.35) {
            n.type = EventType::Refract;
            n.object = pick(24);
            n.medium = toggle(medium);
            const NodeIndex i = h.append(b.node, n);
            stack.push_back({i, n.flux * (pick(2) ? 1.0 : 0.96), b.depth + 1});
        } else if (u < 0.55) {  // Fresnel split: both children of the same parent
            n.object = pick(24);
            n.type = EventType::FresnelReflect;
            const NodeIndex r = h.append(b.node, n);
            n.type = EventType::Refract;
            n.medium = toggle(medium);
            n.direction = unit();
            const NodeIndex t = h.append(b.node, n);
            stack.push_back({r, n.flux * 0.04, b.depth + 1});
            stack.push_back({t, n.flux * 0.96, b.depth + 1});
        } else if (u < 0.60) {
            n.type = EventType::SpecularReflect;
            n.object = pick(24);
            stack.push_back({h.append(b.node, n), n.flux * 0.9, b.depth + 1});
        } else if (u < 0.63) {
            n.type = EventType::TotalInternalReflection;
            n.object = pick(24);
            stack.push_back({h.append(b.node, n), n.flux, b.depth + 1});
        } else if (u < 0.70) {
            const bool transmit = pick(3) == 0;
            n.type = transmit ? EventType::ScatterTransmit : EventType::ScatterReflect;
            n.object = 24 + pick(16);
            n.face = pick(5000);
            n.detail = static_cast<uint8_t>(pick(3));
            if (transmit) n.medium = toggle(medium);
            stack.push_back({h.append(b.node, n), n.flux * 0.05, b.depth + 1});
        } else {
            const int kind = pick(5);
            if (kind == 0) {
                n.type = EventType::SurfaceAbsorb;
                n.object = 24 + pick(16);
                n.face = pick(5000);
            } else if (kind == 1 && medium != 0) {
                n.type = EventType::VolumeAbsorb;
            } else if (kind <= 2) {
                n.type = EventType::Exit;
            } else if (kind == 3) {
                n.type = EventType::DetectorHit;
                n.object = 40;
                n.face = pick(2);
            } else {
                n.type = EventType::Culled;
                n.detail = static_cast<uint8_t>(pick(2) ? CullReason::MinFlux
                                                        : CullReason::RussianRoulette);
            }
            h.append(b.node, n);
        }
    }
    return h;
}

// Checks that `decoded` is `original` as stored with `enc`: exact ids, types, media and tree;
// values rounded to float32 unless double precision; geometry zero where not stored.
void expectStored(const PathHistory& original, const PathHistory& decoded,
                  const PathEncoding& enc) {
    auto q = [&](double v) { return enc.doublePrecision ? v : static_cast<double>(float(v)); };
    ASSERT_EQ(original.size(), decoded.size());
    EXPECT_EQ(original.source(), decoded.source());
    EXPECT_EQ(std::bit_cast<uint32_t>(original.wavelengthNm()),
              std::bit_cast<uint32_t>(decoded.wavelengthNm()));
    EXPECT_EQ(decoded.hasPositions(), enc.positions);
    EXPECT_EQ(decoded.hasDirections(), enc.directions);
    for (NodeIndex i = 0; i < static_cast<NodeIndex>(original.size()); ++i) {
        const PathNode& a = original.node(i);
        const PathNode& d = decoded.node(i);
        ASSERT_EQ(a.parent, d.parent) << "node " << i;
        ASSERT_EQ(a.type, d.type) << "node " << i;
        ASSERT_EQ(a.object, d.object) << "node " << i;
        ASSERT_EQ(a.face, d.face) << "node " << i;
        ASSERT_EQ(a.medium, d.medium) << "node " << i;
        ASSERT_EQ(a.detail, d.detail) << "node " << i;
        ASSERT_EQ(a.hasChildren, d.hasChildren) << "node " << i;
        ASSERT_EQ(q(a.flux), d.flux) << "node " << i;
        for (int k = 0; k < 3; ++k) {
            ASSERT_EQ(enc.positions ? q(a.position[k]) : 0.0, d.position[k]) << "node " << i;
            ASSERT_EQ(enc.directions ? q(a.direction[k]) : 0.0, d.direction[k]) << "node " << i;
        }
    }
}

namespace {

// The tree drawn in path_history.h: a refraction at L1.front, then a split at L1.back.
PathHistory exampleTree() {
    PathHistory h;
    h.start(2, 587.56f, Vec3(0, 0, -10), Vec3(0, 0, 1), 1.0, 0);
    PathNode n;
    n.type = EventType::Refract;
    n.object = 0;
    n.medium = 1;
    n.position = Vec3(0, 0, 0);
    n.direction = Vec3(0, 0.1, 0.995);
    n.flux = 1.0;
    const NodeIndex front = h.append(0, n);
    n.position = Vec3(0, 0.5, 5);
    n.object = 1;
    n.flux = 0.96;  // after the front face's T
    n.medium = 0;
    n.direction = Vec3(0, 0, 1);
    const NodeIndex back = h.append(front, n);  // 2
    n.type = EventType::FresnelReflect;
    n.medium = 1;
    n.direction = Vec3(0, 0, -1);
    const NodeIndex ghost = h.append(front, n);  // 3: sibling of 2
    PathNode hit;
    hit.type = EventType::DetectorHit;
    hit.object = 7;
    hit.face = 1;
    hit.position = Vec3(0, 0.5, 50);
    hit.direction = Vec3(0, 0, 1);
    hit.flux = 0.96 * 0.96;
    h.append(back, hit);  // 4
    PathNode exit;
    exit.type = EventType::Exit;
    exit.medium = 1;
    exit.position = Vec3(0, 0.5, -100);
    exit.direction = Vec3(0, 0, -1);
    exit.flux = 0.96 * 0.04;
    h.append(ghost, exit);  // 5
    return h;
}

TEST(PathHistory, ExampleTreeHasTwoPathsSharingTheirPrefix) {
    const PathHistory h = exampleTree();
    ASSERT_EQ(h.size(), 6u);
    EXPECT_EQ(h.source(), 2);
    EXPECT_EQ(h.pathCount(), 2u);
    std::vector<std::vector<NodeIndex>> paths;
    std::vector<std::vector<PathEvent>> events;
    h.forEachPath([&](const PathView& p) {
        paths.emplace_back();
        events.emplace_back();
        for (size_t i = 0; i < p.size(); ++i) paths.back().push_back(p.node(i));
        for (PathEvent e : p) events.back().push_back(e);
    });
    ASSERT_EQ(paths.size(), 2u);
    EXPECT_EQ(paths[0], (std::vector<NodeIndex>{0, 1, 2, 4}));
    EXPECT_EQ(paths[1], (std::vector<NodeIndex>{0, 1, 3, 5}));

    // Events carry the medium before (the parent's) and after.
    const std::vector<PathEvent> expected0 = {
        {EventType::Emit, 2, 0, 0, 0, 1.0f},
        {EventType::Refract, 0, 0, 0, 1, 1.0f},
        {EventType::Refract, 1, 0, 1, 0, 0.96f},
        {EventType::DetectorHit, 7, 1, 0, 0, float(0.96 * 0.96)},
    };
    const std::vector<PathEvent> expected1 = {
        {EventType::Emit, 2, 0, 0, 0, 1.0f},
        {EventType::Refract, 0, 0, 0, 1, 1.0f},
        {EventType::FresnelReflect, 1, 0, 1, 1, 0.96f},
        {EventType::Exit, -1, 0, 1, 1, float(0.96 * 0.04)},
    };
    EXPECT_EQ(events[0], expected0);
    EXPECT_EQ(events[1], expected1);

    // The segment ending at the ghost reflection runs from the front face along the
    // refracted direction inside glass 1.
    const Segment s = h.segment(3);
    EXPECT_EQ(s.start, Vec3(0, 0, 0));
    EXPECT_EQ(s.end, Vec3(0, 0.5, 5));
    EXPECT_EQ(s.direction, Vec3(0, 0.1, 0.995));
    EXPECT_EQ(s.medium, 1);
    EXPECT_EQ(s.event, EventType::FresnelReflect);
    EXPECT_EQ(s.flux, 0.96);
    EXPECT_EQ(s.wavelengthNm, 587.56f);
    // The emission is a zero-length segment at the source.
    const Segment e = h.segment(0);
    EXPECT_EQ(e.start, e.end);
    EXPECT_EQ(e.event, EventType::Emit);
    EXPECT_EQ(e.object, 2);

    std::ostringstream os;
    os << h;
    EXPECT_NE(os.str().find("fresnel_reflect parent 1 object 1"), std::string::npos) << os.str();
}

TEST(PathHistory, StartBeginsANewRayAndAppendChecksItsParent) {
    PathHistory h = exampleTree();
    h.start(0, 500.0f, Vec3(0.0), Vec3(0, 0, 1), 2.0, 0);
    EXPECT_EQ(h.size(), 1u);
    EXPECT_EQ(h.pathCount(), 1u);  // a lone emission is a (trivial) path
    PathNode n;
    n.type = EventType::Exit;
    EXPECT_THROW(h.append(1, n), std::invalid_argument);   // no node 1 yet
    EXPECT_THROW(h.append(-1, n), std::invalid_argument);  // a second root
    n.type = EventType::Emit;
    EXPECT_THROW(h.append(0, n), std::invalid_argument);
    n.type = EventType::Exit;
    n.face = -3;
    EXPECT_THROW(h.append(0, n), std::invalid_argument);
    n.face = 0;
    EXPECT_EQ(h.append(0, n), 1);
    EXPECT_TRUE(h.node(0).hasChildren);
    EXPECT_TRUE(h.isLeaf(1));
}

TEST(EventType, NamesRoundTrip) {
    for (int i = 0; i < kEventTypeCount; ++i) {
        const auto t = static_cast<EventType>(i);
        EXPECT_EQ(eventTypeFromString(toString(t)), t);
    }
    EXPECT_EQ(toString(EventType::FresnelReflect), "fresnel_reflect");
    EXPECT_EQ(toString(EventType::TotalInternalReflection), "tir");
    EXPECT_FALSE(eventTypeFromString("bounce").has_value());
    EXPECT_TRUE(isTerminal(EventType::Exit));
    EXPECT_FALSE(isTerminal(EventType::DetectorHit));
}

TEST(PathEncoding, VarintsAndZigzagRoundTripAtTheEdges) {
    const uint64_t values[] = {0, 1, 127, 128, 16383, 16384, (1ull << 63) - 1, 1ull << 63, ~0ull};
    for (uint64_t v : values) {
        std::vector<uint8_t> b;
        putVarint(b, v);
        size_t pos = 0;
        EXPECT_EQ(getVarint(b, pos), v);
        EXPECT_EQ(pos, b.size());
    }
    const int64_t signedValues[] = {0, -1, 1, -64, 64, INT64_MIN, INT64_MAX};
    for (int64_t v : signedValues) EXPECT_EQ(unzigzag(zigzag(v)), v);
    EXPECT_EQ(zigzag(-1), 1u);
    EXPECT_EQ(zigzag(1), 2u);
    // Eleven continuation bytes, and a 10-byte varint above 2^64.
    std::vector<uint8_t> tooLong(11, 0x80);
    size_t pos = 0;
    EXPECT_THROW(getVarint(tooLong, pos), PathDecodeError);
    std::vector<uint8_t> overflow(9, 0xff);
    overflow.push_back(0x02);
    pos = 0;
    EXPECT_THROW(getVarint(overflow, pos), PathDecodeError);
}

// The byte layout of docs/ray-database.md, checked on the example tree without geometry.
TEST(PathEncoding, ExampleTreeBytesMatchTheDocumentedLayout) {
    const PathHistory h = exampleTree();
    std::vector<uint8_t> b;
    encodeHistory(h, {}, b);
    auto f32 = [](float v) {
        const uint32_t u = std::bit_cast<uint32_t>(v);
        return std::vector<uint8_t>{uint8_t(u), uint8_t(u >> 8), uint8_t(u >> 16),
                                    uint8_t(u >> 24)};
    };
    std::vector<uint8_t> expected = f32(587.56f);
    expected.push_back(6);  // events
    // 0 Emit: tag 0x00, object = source 2 -> 3, flux 1.0
    expected.insert(expected.end(), {0x00, 3});
    for (uint8_t x : f32(1.0f)) expected.push_back(x);
    // 1 Refract L1.front: medium 0 -> 1 (M, zigzag +1 = 2), same flux (S): tag 0x61
    expected.insert(expected.end(), {0x61, 1, 2});
    // 2 Refract L1.back: medium 1 -> 0 (zigzag -1 = 1), flux 0.96: tag 0x21
    expected.insert(expected.end(), {0x21, 2, 1});
    for (uint8_t x : f32(0.96f)) expected.push_back(x);
    // 3 FresnelReflect L1.back, parent 1 (P, distance 3 - 1 - 1 = 1); its parent arrived
    //   with 1.0, it arrives with 0.96, so the flux is stored: tag 0x83
    expected.insert(expected.end(), {0x83, 1, 2});
    for (uint8_t x : f32(0.96f)) expected.push_back(x);
    // 4 DetectorHit object 7 face 1, parent 2 (P, distance 4 - 1 - 2 = 1): tag 0x9a
    expected.insert(expected.end(), {0x9a, 1, 8, 1});
    for (uint8_t x : f32(float(0.96 * 0.96))) expected.push_back(x);
    // 5 Exit, object -1 -> 0, parent 3 (P, distance 5 - 1 - 3 = 1): tag 0x89
    expected.insert(expected.end(), {0x89, 1, 0});
    for (uint8_t x : f32(float(0.96 * 0.04))) expected.push_back(x);
    EXPECT_EQ(b, expected);
}

TEST(PathEncoding, RandomSplitTreesRoundTripExactly) {
    const PathEncoding encodings[] = {
        {false, false, false}, {true, false, false}, {true, true, false},
        {false, true, false},  {true, true, true},
    };
    std::vector<uint8_t> bytes, again;
    PathHistory decoded;
    size_t splits = 0;
    for (uint64_t ray = 0; ray < 2000; ++ray) {
        const PathHistory h = randomHistory(12345, ray, 1 + static_cast<int>(ray % 300));
        splits += h.pathCount() - 1;
        for (const PathEncoding& enc : encodings) {
            bytes.assign({0xAA});  // decoding starts mid-buffer
            encodeHistory(h, enc, bytes);
            size_t pos = 1;
            decodeHistory(bytes, pos, enc, decoded);
            ASSERT_EQ(pos, bytes.size());
            expectStored(h, decoded, enc);
            if (::testing::Test::HasFatalFailure()) {
                FAIL() << "ray " << ray << " " << enc << "\n" << h;
            }
            // Decoded histories encode to the same bytes, and in double precision with all
            // geometry the round trip is the identity.
            again.assign({0xAA});
            encodeHistory(decoded, enc, again);
            ASSERT_EQ(again, bytes) << "ray " << ray << " " << enc;
            if (enc.positions && enc.directions && enc.doublePrecision) {
                ASSERT_EQ(decoded, h) << "ray " << ray;
            }
        }
    }
    EXPECT_GT(splits, 2000u);  // the trees did branch
}

// Bytes per event of the encoding on the random lens-like histories (about 40 % of the
// events repeat their parent's flux). The bounds are the ones docs/ray-database.md states:
// under 7 bytes per event without geometry, under 31 with float32 positions and directions.
TEST(PathEncoding, BytesPerEventStayBelowTheStatedBound) {
    size_t events = 0, topology = 0, geometry = 0;
    std::vector<uint8_t> b;
    for (uint64_t ray = 0; ray < 5000; ++ray) {
        const PathHistory h = randomHistory(777, ray, 200);
        events += h.size();
        b.clear();
        encodeHistory(h, {}, b);
        topology += b.size();
        b.clear();
        encodeHistory(h, {true, true, false}, b);
        geometry += b.size();
    }
    const double perEvent = double(topology) / events;
    const double perEventGeometry = double(geometry) / events;
    std::cout << "[ measured ] " << events << " events: " << perEvent
              << " bytes/event without geometry, " << perEventGeometry
              << " with float32 positions and directions (per-history header included)\n";
    RecordProperty("bytes_per_event", std::to_string(perEvent));
    RecordProperty("bytes_per_event_geometry", std::to_string(perEventGeometry));
    EXPECT_LT(perEvent, 7.0);
    EXPECT_LT(perEventGeometry, 31.0);
    EXPECT_GT(perEvent, 2.0);  // a tag and an object at least: a smaller figure is a bug
}

TEST(PathEncoding, CorruptBytesGiveTheOffendingOffset) {
    const PathHistory h = exampleTree();
    std::vector<uint8_t> good;
    encodeHistory(h, {}, good);
    PathHistory out;
    auto errorAt = [&](std::vector<uint8_t> b) -> long {
        size_t pos = 0;
        try {
            decodeHistory(b, pos, {}, out);
        } catch (const PathDecodeError& e) {
            return static_cast<long>(e.offset());
        }
        return -1;
    };
    // Every truncation fails, at or before the cut.
    for (size_t n = 0; n < good.size(); ++n) {
        const long at = errorAt(std::vector<uint8_t>(good.begin(), good.begin() + n));
        EXPECT_GE(at, 0) << "cut at " << n;
        EXPECT_LE(at, static_cast<long>(n)) << "cut at " << n;
    }
    std::vector<uint8_t> b = good;
    b[5] = 0x0c;  // node 0's tag: event type 12 does not exist
    EXPECT_EQ(errorAt(b), 5);
    b = good;
    b[5] = 0x01;  // the first event is not an emission
    EXPECT_EQ(errorAt(b), 5);
    b = good;
    b[4] = 0x7f;  // 127 events in the 38 bytes left
    EXPECT_EQ(errorAt(b), 4);
    b = good;
    b[22] = 5;  // node 3's parent distance: no such node
    EXPECT_EQ(errorAt(b), 22);
    b = good;
    b[5] = 0x40;  // the emission claims its parent's flux
    EXPECT_EQ(errorAt(b), 5);
    // Random byte flips never crash: they decode or throw PathDecodeError.
    CounterRng rng(3, 0);
    for (int trial = 0; trial < 20000; ++trial) {
        b = good;
        const int flips = 1 + trial % 3;
        for (int f = 0; f < flips; ++f) {
            b[static_cast<size_t>(rng.uniform() * b.size())] ^= uint8_t(1 + rng.uniform() * 255);
        }
        size_t pos = 0;
        try {
            decodeHistory(b, pos, {}, out);
            EXPECT_LE(pos, b.size());
        } catch (const PathDecodeError&) {
        }
    }
}

// A ray database stores histories back to back: a long stream (2e5 events, float32 geometry)
// decodes history by history to the stored values, each decode stopping exactly where the
// next history begins. The encode and decode rates are measured in bench/kernels_bench.cpp
// (BM_EncodeHistories, BM_DecodeHistories), not asserted here.
TEST(PathEncoding, ConcatenatedHistoriesDecodeOneAfterAnother) {
    std::vector<PathHistory> histories;
    size_t events = 0;
    for (uint64_t ray = 0; events < 200000; ++ray) {
        histories.push_back(randomHistory(99, ray, 400));
        events += histories.back().size();
    }
    const PathEncoding enc{true, true, false};
    std::vector<uint8_t> bytes;
    std::vector<size_t> ends;  // where each history's bytes end
    for (const PathHistory& h : histories) {
        encodeHistory(h, enc, bytes);
        ends.push_back(bytes.size());
    }
    PathHistory out;
    size_t pos = 0;
    for (size_t i = 0; i < histories.size(); ++i) {
        decodeHistory(bytes, pos, enc, out);
        ASSERT_EQ(pos, ends[i]) << "history " << i;
        expectStored(histories[i], out, enc);
        if (::testing::Test::HasFatalFailure()) FAIL() << "history " << i;
    }
    EXPECT_EQ(pos, bytes.size());
    EXPECT_GT(histories.size(), 100u);  // a stream of many histories, not a few long ones
}

}  // namespace
}  // namespace veil
