// Solids of revolution against closed forms: the volume of the chordal (inscribed polygon)
// solid, V N sin(2 pi / N) / (2 pi) with V from Pappus, the chord error r (1 - cos(pi / N)),
// and the mesh structure at the axis.

#include "geometry/revolve.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>

#include "geometry/mesh_check.h"
#include "geometry/numerics.h"

namespace veil {
namespace {

// Signed volume by the divergence theorem, sum of det(v0, v1, v2) / 6: an oracle that does
// not share code with CGAL's.
double signedVolume(const TriangleMesh& m) {
    long double v = 0.0L;
    for (const auto& t : m.triangles) {
        const Vec3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
        v += static_cast<long double>(glm::dot(a, glm::cross(b, c)));
    }
    return static_cast<double>(v / 6.0L);
}

double polygonFactor(int n) { return n * std::sin(2.0 * kPi / n) / (2.0 * kPi); }

std::vector<Vec2> ring(double a, double b, double z0, double z1) {
    return {{a, z0}, {b, z0}, {b, z1}, {a, z1}};
}

// Chord Error and Segment Count

TEST(Revolve, SegmentCountIsTheSmallestMeetingTheTolerance) {
    for (double r : {0.5, 3.0, 12.9, 114.0, 1000.0}) {
        for (double tol : {1.0, 0.1, 0.01, 0.001, 1e-5}) {
            const int n = chordSegmentCount(r, tol);
            EXPECT_LE(chordError(r, n), tol) << "r " << r << " tol " << tol;
            if (n > 3) {
                EXPECT_GT(chordError(r, n - 1), tol) << "r " << r << " tol " << tol;
            }
        }
    }
    EXPECT_EQ(chordSegmentCount(1.0, 0.6), 3);
    EXPECT_EQ(chordSegmentCount(0.0, 0.01), 3);
    EXPECT_THROW(chordSegmentCount(1.0, 0.0), std::invalid_argument);
    EXPECT_THROW(chordSegmentCount(-1.0, 0.1), std::invalid_argument);
}

TEST(Revolve, ChordErrorBoundHoldsOnTheMesh) {
    // Points of the outer wall of a ring lie between r cos(pi / N) and r from the axis; the
    // midpoints of the chords reach the bound exactly.
    const double a = 6.0, b = 10.0, tol = 0.02;
    const int n = chordSegmentCount(b, tol);
    const RevolvedMesh rm = revolveProfile(ring(a, b, 0.0, 4.0), n);
    double worst = 0.0;
    for (const auto& t : rm.mesh.triangles) {
        for (int e = 0; e < 3; ++e) {
            const Vec3 p = 0.5 * (rm.mesh.vertices[t[e]] + rm.mesh.vertices[t[(e + 1) % 3]]);
            const double r = std::hypot(p.x, p.y);
            if (std::abs(r - b) < 0.5) worst = std::max(worst, b - r);
            EXPECT_LE(r, b + 1e-12);
        }
    }
    EXPECT_NEAR(worst, chordError(b, n), 1e-12);
    EXPECT_LE(worst, tol);
    std::cout << "[ chord    ] r = " << b << " mm, tol " << tol << " mm: N = " << n
              << ", worst chord error on the mesh " << worst << " mm\n";
}

// Volumes

TEST(Revolve, RingVolumeIsThePolygonPrism) {
    // A ring revolved with N segments is a prism over the region between two regular
    // N-gons: (N / 2) sin(2 pi / N) (b^2 - a^2) h, exactly.
    const double a = 5.0, b = 8.0, h = 3.0;
    for (int n : {3, 4, 7, 64, 1000}) {
        const RevolvedMesh rm = revolveProfile(ring(a, b, -1.0, -1.0 + h), n);
        const double expected = 0.5 * n * std::sin(2.0 * kPi / n) * (b * b - a * a) * h;
        EXPECT_NEAR(signedVolume(rm.mesh), expected, 1e-12 * expected) << n;
        EXPECT_EQ(rm.mesh.vertices.size(), 4u * n);
        EXPECT_EQ(rm.mesh.triangles.size(), 8u * n);
    }
    // And the exact solid's volume pi (b^2 - a^2) h from Pappus.
    EXPECT_NEAR(profileRevolvedVolume(ring(a, b, 0.0, h)), kPi * (b * b - a * a) * h, 1e-12);
}

TEST(Revolve, VolumeErrorConvergesQuadratically) {
    // Relative error 1 - N sin(2 pi / N) / (2 pi) ~ (2 pi / N)^2 / 6: four times smaller per
    // doubling of N.
    const std::vector<Vec2> profile = ring(2.0, 3.0, 0.0, 1.0);
    const double exact = profileRevolvedVolume(profile);
    double previous = 0.0;
    for (int n = 16; n <= 1024; n *= 2) {
        const double err = 1.0 - signedVolume(revolveProfile(profile, n).mesh) / exact;
        EXPECT_NEAR(err, std::pow(2.0 * kPi / n, 2) / 6.0, 0.02 * err) << n;
        if (previous > 0.0) {
            EXPECT_NEAR(previous / err, 4.0, 0.05) << n;
        }
        previous = err;
    }
}

TEST(Revolve, AnyProfileKeepsThePolygonFactor) {
    // A non-convex star-shaped profile with random radii: the chordal solid's volume is the
    // exact one times N sin(2 pi / N) / (2 pi), whatever the shape.
    std::mt19937 rng(12345);
    std::uniform_real_distribution<double> u(0.3, 1.0);
    std::vector<Vec2> profile;
    const int k = 23;
    for (int i = 0; i < k; ++i) {
        const double t = 2.0 * kPi * i / k;
        const double rho = 2.0 * u(rng);
        profile.push_back({5.0 + rho * std::cos(t), 1.0 + rho * std::sin(t)});
    }
    for (int n : {5, 48, 301}) {
        const RevolvedMesh rm = revolveProfile(profile, n);
        const double expected = profileRevolvedVolume(profile) * polygonFactor(n);
        EXPECT_NEAR(signedVolume(rm.mesh), expected, 1e-11 * expected) << n;
        EXPECT_TRUE(checkMesh(rm.mesh).valid()) << checkMesh(rm.mesh);
    }
}

// Axis and Structure

TEST(Revolve, AxisVerticesArePolesWithoutDegenerateTriangles) {
    // A solid cylinder: two poles, fans on the end caps, no face for the edge on the axis.
    const double R = 4.0, h = 2.5;
    const int n = 40;
    const std::vector<Vec2> cyl{{0.0, 0.0}, {R, 0.0}, {R, h}, {0.0, h}};
    const RevolvedMesh rm = revolveProfile(cyl, n);
    EXPECT_EQ(rm.mesh.vertices.size(), 2u + 2u * n);
    EXPECT_EQ(rm.mesh.triangles.size(), 4u * n);                      // fan, 2 per quad, fan
    EXPECT_EQ(rm.edgeFirstTriangle.back(), rm.edgeFirstTriangle[3]);  // axis edge: empty
    const MeshCheck c = checkMesh(rm.mesh);
    EXPECT_TRUE(c.valid()) << c;
    EXPECT_EQ(c.degenerateTriangles, 0u);
    EXPECT_NEAR(c.volumeMm3, kPi * R * R * h * polygonFactor(n), 1e-10);

    // A cone and a double cone (two poles, no axis edge between them except the closing one).
    const std::vector<Vec2> cone{{0.0, 0.0}, {3.0, 0.0}, {0.0, 5.0}};
    const RevolvedMesh rc = revolveProfile(cone, n);
    EXPECT_EQ(rc.mesh.vertices.size(), 2u + n);
    EXPECT_TRUE(checkMesh(rc.mesh).valid());
    EXPECT_NEAR(signedVolume(rc.mesh), kPi * 9.0 * 5.0 / 3.0 * polygonFactor(n), 1e-10);
    const std::vector<Vec2> diamond{{0.0, -2.0}, {1.5, 0.0}, {0.0, 2.0}};
    EXPECT_TRUE(checkMesh(revolveProfile(diamond, n).mesh).valid());
}

TEST(Revolve, EdgeRangesHoldTheTrianglesOfEachEdge) {
    const std::vector<Vec2> p{{1.0, 0.0}, {3.0, 0.0}, {3.0, 1.0}, {2.0, 2.0}, {1.0, 1.0}};
    const int n = 12;
    const RevolvedMesh rm = revolveProfile(p, n);
    ASSERT_EQ(rm.edgeFirstTriangle.size(), p.size() + 1);
    for (size_t e = 0; e < p.size(); ++e) {
        const Vec2 a = p[e], b = p[(e + 1) % p.size()];
        EXPECT_EQ(rm.edgeFirstTriangle[e + 1] - rm.edgeFirstTriangle[e], 2u * n);
        for (uint32_t t = rm.edgeFirstTriangle[e]; t < rm.edgeFirstTriangle[e + 1]; ++t) {
            for (uint32_t v : rm.mesh.triangles[t]) {
                const Vec3 q = rm.mesh.vertices[v];
                const Vec2 rz{std::hypot(q.x, q.y), q.z};
                const bool onA = glm::length(rz - a) < 1e-12, onB = glm::length(rz - b) < 1e-12;
                EXPECT_TRUE(onA || onB) << "edge " << e << " vertex " << rz;
            }
        }
    }
}

TEST(Revolve, RejectsBadProfiles) {
    const int n = 8;
    auto bad = [&](std::vector<Vec2> p) {
        EXPECT_THROW(revolveProfile(p, n), std::invalid_argument);
    };
    bad({{1.0, 0.0}, {2.0, 0.0}});                          // too few vertices
    bad({{1.0, 0.0}, {1.0, 1.0}, {2.0, 1.0}, {2.0, 0.0}});  // clockwise
    bad({{-1.0, 0.0}, {2.0, 0.0}, {2.0, 1.0}});             // r < 0
    bad({{1.0, 0.0}, {2.0, 0.0}, {2.0, 0.0}, {2.0, 1.0}});  // repeated vertex
    bad({{1.0, 0.0}, {2.0, 1.0}, {2.0, 0.0}, {1.0, 1.0}});  // bow tie
    bad({{1.0, 0.0}, {3.0, 0.0}, {2.0, 0.0}, {2.0, 1.0}});  // folds back along a line
    bad({{1.0, 0.0}, {2.0, 0.0}, {2.0, std::nan("")}});     // not finite
    EXPECT_THROW(revolveProfile(ring(1, 2, 0, 1), 2), std::invalid_argument);
}

}  // namespace
}  // namespace veil
