// ExactFaceIndex against a loop over every face (the same intersectFace() on each, the same
// tie rule): the index may only skip faces the ray cannot hit, so the nearest face and its t
// must agree exactly. Faces on two axes (one tilted and decentred), one face a hair off its
// group's axis, every shape and aperture kind; rays from random points, parallel to the axis,
// perpendicular to it, from far away, and continuing from the hits they made.

#include "geometry/face_index.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <sstream>

namespace veil {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

ExactCandidate bruteForce(const std::vector<ExactFaceEntry>& faces, const Ray& ray,
                          int startObject) {
    ExactCandidate best;
    best.t = kInf;
    for (size_t i = 0; i < faces.size(); ++i) {
        const ExactFaceEntry& e = faces[i];
        const auto hit =
            intersectFace(e.face, e.frame.toLocal(ray), 0.0, best.t, e.object == startObject);
        if (!hit) continue;
        if (hit->t < best.t || best.entry < 0 ||
            (hit->t == best.t && e.object < faces[best.entry].object)) {
            best.entry = static_cast<int>(i);
            best.t = hit->t;
        }
    }
    return best;
}

Frame tilted(double angle, const Vec3& at) {
    Frame f;
    const double c = std::cos(angle), s = std::sin(angle);
    f.rotation = glm::dmat3(Vec3(1, 0, 0), Vec3(0, c, s), Vec3(0, -s, c));
    f.translation = at;
    return f;
}

std::vector<ExactFaceEntry> testFaces() {
    std::vector<ExactFaceEntry> f;
    auto add = [&](Frame frame, FaceGeometry g) {
        f.push_back({static_cast<int>(f.size()), frame, std::move(g)});
    };
    // A biconvex lens on the z axis with its edge and flats.
    add(Frame::alongAxis(0.0), SurfacePatch{SphereShape{1.0 / 60.0}, CircularAperture{14.0}});
    add(Frame::alongAxis(0.0),
        SurfacePatch{PlaneShape{}, AnnularAperture{14.0, 16.0}});  // flat in front
    add(Frame::alongAxis(8.0), SurfacePatch{SphereShape{-1.0 / 45.0}, CircularAperture{14.0}});
    add(Frame::alongAxis(8.0), SurfacePatch{PlaneShape{}, AnnularAperture{14.0, 16.0}});
    add(Frame::alongAxis(0.0), CylinderPatch{16.0, 0.0, 8.0, true, nullptr});
    // A cemented asphere and a conic mirror with a hole further down the axis.
    std::array<double, 10> a{};
    a[0] = 1e-4;
    a[1] = -2e-7;
    add(Frame::alongAxis(20.0),
        SurfacePatch{EvenAsphereShape{1.0 / 80.0, -0.5, a}, CircularAperture{12.0}});
    add(Frame::alongAxis(40.0),
        SurfacePatch{ConicShape{-1.0 / 120.0, -1.2}, AnnularAperture{4.0, 18.0}});
    // A rectangle, and a flat disc a hair (2e-7 mm) off the axis: both join the axis group.
    add(Frame::alongAxis(30.0), SurfacePatch{PlaneShape{}, RectangularAperture{6.0, 3.0}});
    Frame off = Frame::alongAxis(35.0);
    off.translation.x = 2e-7;
    add(off, SurfacePatch{PlaneShape{}, CircularAperture{5.0}});
    // A tilted, decentred element: its own group.
    add(tilted(0.5, {3.0, -20.0, 25.0}),
        SurfacePatch{SphereShape{1.0 / 30.0}, CircularAperture{6.0}});
    add(tilted(0.5, {3.0, -20.0, 25.0}), CylinderPatch{6.0, -1.0, 2.0, true, nullptr});
    return f;
}

Vec3 unit(std::mt19937_64& rng) {
    std::normal_distribution<double> g;
    return glm::normalize(Vec3{g(rng), g(rng), g(rng)});
}

TEST(ExactFaceIndex, AgreesWithEveryFaceTested) {
    const std::vector<ExactFaceEntry> faces = testFaces();
    const ExactFaceIndex index(faces);
    EXPECT_EQ(index.groupCount(), 2);  // the off-axis disc joined the axis group
    std::mt19937_64 rng(20261127);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int compared = 0, hits = 0, mismatches = 0;
    std::vector<int> hitsOnFace(faces.size(), 0);
    std::string first;
    auto compare = [&](const Ray& ray, int startObject) -> ExactCandidate {
        ExactCandidate got;
        got.t = kInf;
        index.nearest(ray, startObject, got);
        const ExactCandidate want = bruteForce(faces, ray, startObject);
        ++compared;
        if (got.entry != want.entry || (want.entry >= 0 && got.t != want.t)) {
            if (mismatches++ == 0) {
                std::ostringstream os;
                os << "ray " << ray.origin << " -> " << ray.direction << " from " << startObject
                   << ": index " << got.entry << " t " << got.t << ", loop " << want.entry << " t "
                   << want.t;
                first = os.str();
            }
        }
        if (want.entry >= 0) {
            ++hits;
            ++hitsOnFace[want.entry];
        }
        return want;
    };
    for (int i = 0; i < 100000; ++i) {
        const Vec3 o(25.0 * u(rng), 25.0 * u(rng), -10.0 + 30.0 * (u(rng) + 1.0));
        Vec3 d = unit(rng);
        switch (i % 8) {
            case 0:
                d = Vec3(0.0, 0.0, u(rng) < 0.0 ? -1.0 : 1.0);  // along the axis
                break;
            case 1:
                d = glm::normalize(Vec3(d.x, d.y, 0.0));  // across it
                break;
            case 2: {
                // From 1e5 mm away toward a point near the axis.
                const Vec3 target(5.0 * u(rng), 5.0 * u(rng), 20.0 + 20.0 * u(rng));
                const Ray far{target - 1e5 * d, d};
                compare(far, -1);
                continue;
            }
            case 3: {
                // Toward a face's rim (or a hole's), within 1e-9 to 1e-5 of it, either side.
                const ExactFaceEntry& e =
                    faces[static_cast<size_t>((u(rng) + 1.0) * 0.5 * faces.size()) % faces.size()];
                const std::vector<FaceBand> bands = faceBands(e.face, 1);
                const bool hole = u(rng) < -0.5 && bands.front().rLo > 0.0;
                const double rim = hole ? bands.front().rLo : bands.back().rHi;
                const double r =
                    rim * (1.0 + std::copysign(std::pow(10.0, -7.0 + 2.0 * u(rng)), u(rng)));
                const double phi = std::numbers::pi * u(rng);
                const double z = bands.front().zLo +
                                 0.5 * (u(rng) + 1.0) * (bands.front().zHi - bands.front().zLo);
                const Vec3 target =
                    e.frame.toGlobalPoint({r * std::cos(phi), r * std::sin(phi), z});
                compare({target - 30.0 * d, d}, -1);
                continue;
            }
            default:
                break;
        }
        Ray ray{o, d};
        int start = -1;
        // The ray and up to 4 continuations from where it hits, in new random directions
        // (half of them mirrored about the face's tangent plane so they stay near it).
        for (int bounce = 0; bounce < 5; ++bounce) {
            const ExactCandidate hit = compare(ray, start);
            if (hit.entry < 0) break;
            start = faces[hit.entry].object;
            Vec3 next = unit(rng);
            if (bounce % 2 == 1) next = glm::normalize(next + 0.999 * ray.direction);
            ray = {ray.origin + hit.t * ray.direction, next};
        }
    }
    EXPECT_EQ(mismatches, 0) << mismatches << " of " << compared << "; first: " << first;
    EXPECT_GT(hits, compared / 4);
    for (size_t f = 0; f < faces.size(); ++f) EXPECT_GE(hitsOnFace[f], 20) << "face " << f;
}

TEST(ExactFaceIndex, BandsHoldTheirFace) {
    // Every sampled point of a face lies in one of its bands.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (const ExactFaceEntry& e : testFaces()) {
        const std::vector<FaceBand> bands = faceBands(e.face, 4);
        const TriangleMesh mesh = tessellateFace(e.face, 1e-4);
        for (const Vec3& p : mesh.vertices) {
            const double r = std::hypot(p.x, p.y);
            bool inside = false;
            for (const FaceBand& b : bands)
                inside = inside || (r >= b.rLo && r <= b.rHi && p.z >= b.zLo && p.z <= b.zHi);
            EXPECT_TRUE(inside) << "point " << p << " of object " << e.object;
        }
    }
}

}  // namespace
}  // namespace veil
