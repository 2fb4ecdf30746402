// Mesh checks on meshes whose defects are known by construction: generated solids are
// valid; a missing triangle leaves exactly its three edges open; a vertex pushed through
// the opposite wall makes the surface cross itself; reversed triangles turn it inside out.

#include "geometry/mesh_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "geometry/cgal_mesh.h"
#include "geometry/numerics.h"
#include "geometry/revolve.h"

namespace veil {
namespace {

TriangleMesh ringMesh(double a, double b, double z0, double z1, int n) {
    const std::vector<Vec2> p{{a, z0}, {b, z0}, {b, z1}, {a, z1}};
    return revolveProfile(p, n).mesh;
}

// A closed box [lo, hi], outward.
TriangleMesh box(Vec3 lo, Vec3 hi) {
    TriangleMesh m;
    for (int i = 0; i < 8; ++i)
        m.vertices.emplace_back(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                   {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    return m;
}

// Generated Meshes

TEST(MeshCheck, RevolvedRingIsValid) {
    const int n = 64;
    const MeshCheck c = checkMesh(ringMesh(5.0, 8.0, 0.0, 3.0, n));
    EXPECT_TRUE(c.valid()) << c;
    EXPECT_TRUE(c.closed());
    EXPECT_EQ(c.borderEdges, 0u);
    EXPECT_EQ(c.selfIntersections, 0u);
    EXPECT_TRUE(c.outward);
    EXPECT_NEAR(c.volumeMm3, 0.5 * n * std::sin(2.0 * kPi / n) * (64.0 - 25.0) * 3.0, 1e-9);
    EXPECT_EQ(c.problems(), "");
}

TEST(MeshCheck, BoxIsValid) {
    const MeshCheck c = checkMesh(box({0, 0, 0}, {1, 2, 3}));
    EXPECT_TRUE(c.valid()) << c;
    EXPECT_NEAR(c.volumeMm3, 6.0, 1e-12);
}

// Broken Meshes

TEST(MeshCheck, MissingTriangleLeavesThreeBorderEdges) {
    TriangleMesh m = ringMesh(5.0, 8.0, 0.0, 3.0, 32);
    m.triangles.erase(m.triangles.begin() + 17);
    const MeshCheck c = checkMesh(m);
    EXPECT_EQ(c.borderEdges, 3u);
    EXPECT_FALSE(c.closed());
    EXPECT_FALSE(c.valid());
    EXPECT_TRUE(std::isnan(c.volumeMm3));
    EXPECT_NE(c.problems().find("3 border edges"), std::string::npos) << c.problems();
    // Both triangles of that quad gone (16 and 17 share its diagonal): one hole of four
    // edges.
    m.triangles.erase(m.triangles.begin() + 16);
    EXPECT_EQ(checkMesh(m).borderEdges, 4u);
}

TEST(MeshCheck, FoldedVertexIsASelfIntersection) {
    // Push one vertex of the ring's outer wall through the inner wall to the far side.
    const int n = 24;
    TriangleMesh m = ringMesh(5.0, 8.0, 0.0, 3.0, n);
    const MeshCheck before = checkMesh(m);
    ASSERT_TRUE(before.valid());
    // Vertex n + 3 is on the outer bottom ring (profile vertex 1, meridian 3).
    Vec3& v = m.vertices[n + 3];
    v = Vec3(-v.x, -v.y, v.z + 1.5);
    const MeshCheck c = checkMesh(m);
    EXPECT_TRUE(c.closed()) << c;  // the connectivity is untouched
    EXPECT_GT(c.selfIntersections, 0u) << c;
    EXPECT_FALSE(c.valid());
    EXPECT_NE(c.problems().find("self-intersecting"), std::string::npos) << c.problems();
    std::cout << "[ folded   ] " << c << "\n";
}

TEST(MeshCheck, ReversedTrianglesAreInward) {
    TriangleMesh m = box({0, 0, 0}, {2, 2, 2});
    for (auto& t : m.triangles) std::swap(t[1], t[2]);
    const MeshCheck c = checkMesh(m);
    EXPECT_TRUE(c.closed());
    EXPECT_FALSE(c.outward);
    EXPECT_FALSE(c.valid());
    EXPECT_NEAR(c.volumeMm3, -8.0, 1e-12);
    EXPECT_NE(c.problems().find("inward"), std::string::npos);
}

TEST(MeshCheck, OneFlippedTriangleIsInconsistent) {
    TriangleMesh m = box({0, 0, 0}, {1, 1, 1});
    std::swap(m.triangles[4][1], m.triangles[4][2]);
    const MeshCheck c = checkMesh(m);
    EXPECT_EQ(c.misorientedEdges, 3u);
    EXPECT_EQ(c.borderEdges, 0u);
    EXPECT_FALSE(c.closed());
    EXPECT_FALSE(c.valid());
}

TEST(MeshCheck, DegenerateAndNonManifold) {
    TriangleMesh m = box({0, 0, 0}, {1, 1, 1});
    m.vertices.emplace_back(0.5, 0.0, 0.0);  // on the edge from vertex 0 to 1
    m.triangles.push_back({0, 1, 8});        // collinear
    const MeshCheck c = checkMesh(m);
    EXPECT_EQ(c.degenerateTriangles, 1u);
    EXPECT_FALSE(c.valid());
    // A third triangle on the edge 0-1 makes it non-manifold; CGAL cannot hold that.
    TriangleMesh fin = box({0, 0, 0}, {1, 1, 1});
    fin.vertices.emplace_back(0.5, -1.0, -1.0);
    fin.triangles.push_back({0, 1, 8});
    const MeshCheck f = checkMesh(fin);
    EXPECT_EQ(f.nonManifoldEdges, 1u);
    EXPECT_FALSE(f.polygonMesh);
    EXPECT_FALSE(f.valid());
}

// Two Meshes

TEST(MeshCheck, MeshesIntersect) {
    const int n = 48;
    const TriangleMesh outer = ringMesh(10.0, 12.0, 0.0, 5.0, n);
    // Nested with a 1 um gap, same segment count: apart.
    EXPECT_FALSE(meshesIntersect(outer, ringMesh(8.0, 10.0 - 0.001, 0.0, 5.0, n)));
    // Overlapping radially.
    EXPECT_TRUE(meshesIntersect(outer, ringMesh(8.0, 10.5, 1.0, 2.0, n)));
    // Touching along a plane counts.
    EXPECT_TRUE(meshesIntersect(outer, ringMesh(10.0, 12.0, 5.0, 6.0, n)));
    // Apart along z.
    EXPECT_FALSE(meshesIntersect(outer, ringMesh(10.0, 12.0, 5.001, 6.0, n)));
    // One solid wholly inside the other: no triangles cross, the volumes overlap.
    EXPECT_TRUE(meshesIntersect(box({0, 0, 0}, {10, 10, 10}), box({4, 4, 4}, {5, 5, 5})));
    EXPECT_FALSE(meshesIntersect(box({0, 0, 0}, {1, 1, 1}), box({2, 0, 0}, {3, 1, 1})));
}

// Conversion

TEST(MeshCheck, CgalRoundTripKeepsVerticesAndTriangles) {
    const TriangleMesh m = ringMesh(1.0, 2.0, 0.0, 1.0, 10);
    const TriangleMesh back = fromCgalMesh(toCgalMesh(m));
    ASSERT_EQ(back.vertices.size(), m.vertices.size());
    ASSERT_EQ(back.triangles.size(), m.triangles.size());
    for (size_t i = 0; i < m.vertices.size(); ++i) EXPECT_EQ(back.vertices[i], m.vertices[i]);
    // Same triangles up to a rotation of their corners.
    for (size_t i = 0; i < m.triangles.size(); ++i) {
        const auto &a = m.triangles[i], &b = back.triangles[i];
        const bool same = (a == b) || (a == std::array<uint32_t, 3>{b[1], b[2], b[0]}) ||
                          (a == std::array<uint32_t, 3>{b[2], b[0], b[1]});
        EXPECT_TRUE(same) << i;
    }
    TriangleMesh fin = box({0, 0, 0}, {1, 1, 1});
    fin.vertices.emplace_back(0.5, -1.0, -1.0);
    fin.triangles.push_back({0, 1, 8});
    EXPECT_THROW(toCgalMesh(fin), std::invalid_argument);
}

}  // namespace
}  // namespace veil
