// Light traced from small lit parts to the sensor (tracer/render/part_light.h) against
// independent truth: a 50 um tall ring (the bore of a washer behind a singlet's focus, a
// stop's knife edge) lit by a collimated beam through the singlet and seen through a second
// singlet. The truth is a quadrature through the sequential model (traceSequential, its own
// intersections and Snell's law): the flux each ray of the beam brings to the bore, times the
// Lambertian bore's projected solid angle of the directions that reach the sensor through the
// second singlet. Also: the part's point map and its inverse, and the renderer with the parts
// on and off.

#include "tracer/render/part_light.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "lensdata/glass_catalog.h"
#include "tests/tracer/render/box_mesh.h"
#include "tracer/render/path_judge.h"
#include "tracer/render/render.h"
#include "tracer/runtime/rng.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {
namespace {

constexpr double kBore = 2.5;         // the ring's radius (mm)
constexpr double kZ0 = 130.0;         // its front (mm from the first vertex)
constexpr double kHeight = 0.05;      // its height
constexpr double kBaffleHole = 11.0;  // nothing through it passes beside the second singlet
constexpr double kBaffleZ = 153.5;
constexpr double kDetectorHalf = 30.0;
constexpr double kReflectance = 0.5;

// A closed washer (OFF): inner radius rIn, outer rOut, from z0 to z1, n segments, outward
// faces; the bore's triangles first.
void writeWasher(const std::string& path, double rIn, double rOut, double z0, double z1, int n) {
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fprintf(f, "OFF\n%d %d 0\n", 4 * n, 8 * n);
    // Vertex 4 i + {0: inner front, 1: inner back, 2: outer front, 3: outer back}.
    std::vector<Vec3> v;
    for (int i = 0; i < n; ++i) {
        const double phi = 2.0 * std::numbers::pi * i / n;
        const double c = std::cos(phi), s = std::sin(phi);
        for (const auto& [r, z] : {std::pair{rIn, z0}, {rIn, z1}, {rOut, z0}, {rOut, z1}}) {
            v.emplace_back(r * c, r * s, z);
            fprintf(f, "%.17g %.17g %.17g\n", r * c, r * s, z);
        }
    }
    // Two triangles of the quad (a, b, c, d), turned so that their normal points along `out`.
    auto quad = [&](int a, int b, int c, int d, const Vec3& out) {
        for (const auto& t : {std::array<int, 3>{a, b, c}, std::array<int, 3>{a, c, d}}) {
            const Vec3 nrm = glm::cross(v[t[1]] - v[t[0]], v[t[2]] - v[t[0]]);
            if (glm::dot(nrm, out) >= 0.0)
                fprintf(f, "3 %d %d %d\n", t[0], t[1], t[2]);
            else
                fprintf(f, "3 %d %d %d\n", t[0], t[2], t[1]);
        }
    };
    auto at = [&](int i, int k) { return 4 * (i % n) + k; };
    auto radial = [&](int i) {
        const double phi = 2.0 * std::numbers::pi * (i + 0.5) / n;
        return Vec3(std::cos(phi), std::sin(phi), 0.0);
    };
    for (int i = 0; i < n; ++i) quad(at(i, 0), at(i + 1, 0), at(i + 1, 1), at(i, 1), -radial(i));
    for (int i = 0; i < n; ++i) {
        quad(at(i, 2), at(i + 1, 2), at(i + 1, 3), at(i, 3), radial(i));
        quad(at(i, 0), at(i + 1, 0), at(i + 1, 2), at(i, 2), Vec3(0.0, 0.0, -1.0));
        quad(at(i, 1), at(i + 1, 1), at(i + 1, 3), at(i, 3), Vec3(0.0, 0.0, 1.0));
    }
    fclose(f);
}

// Two biconvex singlets (n 1.5, ideal antireflection, clear radius 12.5 mm, f about 100 mm)
// 150 mm apart; the white washer's bore 28 mm behind the first one's focus, where the beam
// diverges; an absorbing baffle in front of the second singlet; the sensor 30 mm behind it.
std::unique_ptr<PreparedScene> ringScene(double heightMm = kHeight) {
    const std::string stem = ::testing::TempDir() + "veil_part_light_" +
                             std::to_string(static_cast<int>(1e3 * heightMm));
    writeWasher(stem + "_ring.off", kBore, 12.0, kZ0, kZ0 + heightMm, 720);
    writeWasher(stem + "_baffle.off", kBaffleHole, 60.0, kBaffleZ, kBaffleZ + 1.0, 90);
    const std::string path = stem + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f,
            "%s"
            "  { r = 100.0, t = 5.0, glass = { nd = 1.5, vd = 0.0 }, sd = 12.5 },\n"
            "  { r = -100.0, t = 30.0, sd = 12.5 },\n"
            "  { image = true, sd = 45.0 },\n]\n"
            "[[mesh]]\nname = \"ring\"\nfile = \"%s\"\nproperty = \"white\"\n"
            "[[mesh]]\nname = \"baffle\"\nfile = \"%s\"\nproperty = \"absorber\"\n"
            "[properties.white]\nscatter = { model = \"lambertian\", reflectance = %g }\n"
            "[[source]]\nname = \"beam\"\nkind = \"collimated\"\nradius_mm = 10.0\n"
            "irradiance_w_mm2 = 1.0\n"
            "[detector]\nsize_mm = [%g, %g]\npixels = [16, 16]\n"
            "[[assign]]\nobjects = [\"L1.*\", \"L2.*\"]\nproperty = \"ideal_ar\"\n",
            singletSystem(150.0).c_str(),
            std::filesystem::path(stem + "_ring.off").filename().c_str(),
            std::filesystem::path(stem + "_baffle.off").filename().c_str(), kReflectance,
            2.0 * kDetectorHalf, 2.0 * kDetectorHalf);
    fclose(f);
    return PreparedScene::read(path, GlassCatalog::builtIn());
}

// The truth. A ray of the beam at height h crosses the first singlet and meets the bore
// where it first reaches radius kBore between kZ0 and kZ0 + kHeight (diverging behind the
// focus); the flux of the annulus 2 pi h dh arrives there. The Lambertian bore sends
// (rho / pi) cos dw of it into dw; G(z) integrates cos over the directions that cross the
// baffle's hole and the second singlet and land on the sensor's square, by a polar grid over
// the plane of the second singlet's vertex (dw = cos_plane dA / d^2).
double bandZ(const SequentialModel& m, double h) {
    SequentialTraceOptions o;
    o.lastSurface = 2;
    const SequentialRayResult r = traceSequential(m, 0, Ray{Vec3(0.0, h, -1.0), Vec3(0, 0, 1)}, o);
    if (!r.ok()) return -1.0;
    // y(z) = y0 + (z - z0) dy / dz; behind the focus y < 0: y = -kBore.
    const Ray& e = r.ray;
    return e.origin.z + (-kBore - e.origin.y) / e.direction.y * e.direction.z;
}

double projectedSolidAngle(const SequentialModel& m, double z, double height) {
    const Vec3 x(0.0, kBore, z);  // on the bore, its normal toward the axis: -y
    const Vec3 normal(0.0, -1.0, 0.0);
    const double zPlane = 155.0;  // the second singlet's front vertex
    constexpr int kRings = 240, kSectors = 480;
    const double rMax = 13.0;
    double sum = 0.0;
    SequentialTraceOptions o;
    o.firstSurface = 3;
    for (int i = 0; i < kRings; ++i) {
        const double r0 = rMax * i / kRings, r1 = rMax * (i + 1) / kRings;
        const double rm = 0.5 * (r0 + r1);
        const double dA = 0.5 * (r1 * r1 - r0 * r0) * 2.0 * std::numbers::pi / kSectors;
        for (int j = 0; j < kSectors; ++j) {
            const double phi = 2.0 * std::numbers::pi * (j + 0.5) / kSectors;
            const Vec3 y(rm * std::cos(phi), rm * std::sin(phi), zPlane);
            const Vec3 d = y - x;
            const double dist = glm::length(d);
            const Vec3 w = d / dist;
            const double cosX = glm::dot(w, normal);
            if (!(cosX > 0.0)) continue;
            // The bore's far side: where the ray reaches radius kBore again.
            const double a = w.x * w.x + w.y * w.y;
            const double tBack = -2.0 * (x.x * w.x + x.y * w.y) / a;
            if (x.z + tBack * w.z < kZ0 + height) continue;
            // The baffle's hole (its front plane; the hole's wall is 1 mm deep).
            bool blocked = false;
            for (const double zb : {kBaffleZ, kBaffleZ + 1.0}) {
                const Vec3 p = x + (zb - x.z) / w.z * w;
                blocked |= std::hypot(p.x, p.y) > kBaffleHole;
            }
            if (blocked) continue;
            const SequentialRayResult r = traceSequential(m, 0, Ray{x, w}, o);
            if (!r.ok()) continue;
            const Vec3& e = r.ray.origin;  // on the image surface
            if (std::abs(e.x) > kDetectorHalf || std::abs(e.y) > kDetectorHalf) continue;
            sum += cosX * (zPlane - x.z) / dist * dA / (dist * dist);
        }
    }
    return sum;
}

double quadratureFlux(const SequentialModel& m, double height = kHeight) {
    // The heights whose rays meet the bore: bandZ(h) in [kZ0, kZ0 + height] (monotone there).
    auto solve = [&](double z) {
        double lo = 5.0, hi = 10.0;  // bandZ falls as h grows
        for (int i = 0; i < 200; ++i) {
            const double mid = 0.5 * (lo + hi);
            (bandZ(m, mid) > z ? lo : hi) = mid;
        }
        return 0.5 * (lo + hi);
    };
    const double hA = solve(kZ0 + height), hB = solve(kZ0);
    EXPECT_LT(hA, hB);
    // G(z) is smooth over the bore: piecewise linear between kSpans + 1 heights.
    const int spans = height > 0.1 ? 16 : 2;
    std::vector<double> gs;
    for (int i = 0; i <= spans; ++i)
        gs.push_back(projectedSolidAngle(m, kZ0 + height * i / spans, height));
    auto g = [&](double z) {
        const double s = std::clamp((z - kZ0) / height * spans, 0.0, spans - 1e-12);
        const int i = static_cast<int>(s);
        return gs[i] + (s - i) * (gs[i + 1] - gs[i]);
    };
    constexpr int kNodes = 256;
    double flux = 0.0;
    for (int i = 0; i < kNodes; ++i) {
        const double h = hA + (hB - hA) * (i + 0.5) / kNodes;
        const double dh = (hB - hA) / kNodes;
        flux += 2.0 * std::numbers::pi * h * dh * kReflectance / std::numbers::pi * g(bandZ(m, h));
    }
    return flux;
}

// One criterion: the path has no total internal reflection (light the second singlet's butt
// end reflects inside it is not the quadrature's, nor the parts').
class NoTirJudge : public PathJudge {
  public:
    int count() const override { return 1; }
    size_t stateBytes() const override { return 1; }
    void reset(std::byte* state) const override { state[0] = std::byte{0}; }
    uint64_t push(std::byte* state, const PathEvent& e) const override {
        if (e.type == EventType::TotalInternalReflection) state[0] = std::byte{1};
        return state[0] == std::byte{0} ? 1u : 0u;
    }
    uint64_t matches(const std::byte* state, std::span<const PathEvent> suffix,
                     std::byte*) const override {
        if (state[0] != std::byte{0}) return 0;
        for (const PathEvent& e : suffix)
            if (e.type == EventType::TotalInternalReflection) return 0;
        return 1;
    }
    uint64_t suffixMayMatch(std::span<const PathEvent>) const override { return 1; }
};

int objectId(const Scene& scene, const std::string& name) {
    const SceneObject* o = scene.find(name);
    EXPECT_TRUE(o) << name;
    return o ? o->id : -1;
}

// Every point the map draws lies on its object (a ray back along its normal meets the object
// there first), and its density integrates to one: on a mesh, whose triangles are drawn as
// often as each other, the mean of 1 / density over one point per triangle is the area; on an
// exact face, the mean over a fine grid of the map.
TEST(PartLight, PointsLieOnTheirPartAndTheirDensityIntegratesToOne) {
    const auto s = ringScene();
    const Scene& scene = s->scene();
    for (const std::string name : {"ring", "L1.front", "L2.back", "L1.edge"}) {
        const int id = objectId(scene, name);
        const PartShape shape(scene, id);
        ASSERT_TRUE(shape.valid()) << name;
        const bool mesh = name == "ring";
        const int n = mesh ? 8 * 720 : 256;
        double meanInverse = 0.0;
        int on = 0;
        for (int k = 0; k < n; ++k) {
            const double u = mesh ? (k + 0.5) / n : (k % 16 + 0.5) / 16.0;
            const double v = mesh ? 0.37 : (k / 16 + 0.5) / 16.0;
            const auto p = shape.at(u, v);
            ASSERT_TRUE(p) << name;
            meanInverse += 1.0 / p->density / n;
            const auto hit = scene.closestHit({p->point + 1e-3 * p->normal, -p->normal}, 1.0);
            on += hit && hit->object == id && glm::length(hit->point - p->point) < 1e-6;
        }
        EXPECT_EQ(on, n) << name;
        // Closed forms: the washer; a sphere's cap of radius 100 mm over 12.5 mm, 2 pi R sag;
        // the butt end between the two caps' rims, 2 pi r (5 mm - 2 sag).
        const double sag = 100.0 - std::sqrt(100.0 * 100.0 - 12.5 * 12.5);
        const double area = mesh ? 2.0 * std::numbers::pi * (kBore + 12.0) * kHeight +
                                       2.0 * std::numbers::pi * (144.0 - kBore * kBore)
                            : name == "L1.edge" ? 2.0 * std::numbers::pi * 12.5 * (5.0 - 2.0 * sag)
                                                : 2.0 * std::numbers::pi * 100.0 * sag;
        EXPECT_NEAR(meanInverse, area, 1e-3 * area) << name;
        EXPECT_NEAR(shape.areaMm2(), area, 1e-3 * area) << name;
    }
}

// The aimed splats' density (docs/render.md, "Splats aimed through the lens"): a point the
// photon pass finds by tracing (its hit) gets the density with which at() would have drawn it.
// On exact faces uvOf() inverts at() and densityAt() is at()'s density; on a mesh, densityAt()
// of a triangle's point is at()'s density there. A point off the shape has density 0.
TEST(PartLight, DensityAtAPointIsTheDensityTheMapDrawsItWith) {
    const auto s = ringScene();
    const Scene& scene = s->scene();
    for (const std::string name : {"ring", "L1.front", "L2.back", "L1.edge"}) {
        const int id = objectId(scene, name);
        const PartShape shape(scene, id);
        ASSERT_TRUE(shape.valid()) << name;
        const bool exact = name == "L1.front" || name == "L2.back";
        EXPECT_EQ(shape.invertible(), exact) << name;
        CounterRng rng(17, 0);
        for (int k = 0; k < 200; ++k) {
            const double u = rng.uniform(), v = rng.uniform();
            const auto p = shape.at(u, v);
            ASSERT_TRUE(p) << name;
            EXPECT_NEAR(shape.densityAt(p->point, p->primitive), p->density, 1e-9 * p->density)
                << name << " at " << u << ", " << v;
            if (!exact) continue;
            const auto uv = shape.uvOf(p->point);
            ASSERT_TRUE(uv) << name;
            EXPECT_NEAR(uv->x, u, 1e-9) << name;
            // v wraps at 1 (the angle's zero).
            EXPECT_NEAR(std::remainder(uv->y - v, 1.0), 0.0, 1e-9) << name;
        }
        if (exact) {  // beyond the face's clear aperture (12.5 mm)
            const Vec3 off = scene.object(id).frame.toGlobalPoint(Vec3(13.0, 0.0, 0.0));
            EXPECT_EQ(shape.densityAt(off, 0), 0.0) << name;
        }
    }
}

TEST(PartLight, RingBehindASingletAgreesWithQuadrature) {
    const auto s = ringScene();
    const TransportView& ts = s->transport().view;
    const double truth = quadratureFlux(s->model());
    ASSERT_GT(truth, 0.0);
    const LensConnector lc(ts);
    const DetectorImage& det = s->transport().images[0];
    const PartLight parts(ts, lc, det.geometry().object, std::vector<bool>(ts.properties.size()));
    ASSERT_TRUE(parts.any());
    // One direction per point, and 16 sharing each point's solved light
    // (RenderOptions::partDirections): the same light, with less noise per point.
    double sigmaOne = 0.0;
    for (const int directions : {1, 16}) {
        double sum = 0.0, sum2 = 0.0;
        constexpr int kPasses = 16;
        uint64_t found = 0;
        for (int k = 1; k <= kPasses; ++k) {
            const PartLight::Result r = parts.trace(det, 16384, 1000 + static_cast<uint64_t>(k),
                                                    nullptr, false, Ranks::alone(), directions);
            double flux = 0.0;
            for (double p : r.pixels) flux += p;
            sum += flux;
            sum2 += flux * flux;
            found += r.found;
        }
        const double mean = sum / kPasses;
        const double sigma = std::sqrt((sum2 / kPasses - mean * mean) / (kPasses - 1));
        std::cout << "parts, " << directions << " directions a point: " << mean << " +- " << sigma
                  << " (" << found << " directions of " << kPasses * 16384
                  << " points reached a pixel), quadrature " << truth << "\n";
        EXPECT_LE(std::abs(mean - truth), 3.0 * sigma + 1e-3 * truth) << directions;
        EXPECT_LT(sigma, 0.02 * truth) << directions;
        if (directions == 1) {
            sigmaOne = sigma;
        } else {
            EXPECT_LT(sigma, sigmaOne) << directions;
        }
    }
}

// The same pass from one thread and from two: bitwise the same images (sample i draws from its
// own stream, blocks are added in order; the pilot's cells are independent).
TEST(PartLight, OneAndTwoThreadsAreBitwiseTheSame) {
    const auto s = ringScene();
    const TransportView& ts = s->transport().view;
    const DetectorImage& det = s->transport().images[0];
    std::vector<double> images[2];
    for (const int threads : {1, 2}) {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const LensConnector lc(ts);
        const PartLight parts(ts, lc, det.geometry().object,
                              std::vector<bool>(ts.properties.size()));
        images[threads - 1] = parts.trace(det, 8192, 7, nullptr, false, Ranks::alone()).pixels;
    }
    ASSERT_EQ(images[0].size(), images[1].size());
    EXPECT_EQ(0,
              std::memcmp(images[0].data(), images[1].data(), images[0].size() * sizeof(double)));
    double total = 0.0;
    for (double p : images[0]) total += p;
    EXPECT_GT(total, 0.0);
}

// Where pixel rays find the ring (a 1 mm bore), the view points and the parts estimate the same
// light: with the parts (the view points leaving the parts' cells to them and keeping the
// rest) and without, the renderer's light of the designed path (the criterion: no total
// internal reflection) agrees with the quadrature; the parts' error is the smaller.
TEST(PartLight, RendererAgreesWithQuadratureWithAndWithoutTheParts) {
    const auto s = ringScene(1.0);
    const double truth = quadratureFlux(s->model(), 1.0);
    const TransportView& ts = s->transport().view;
    const DetectorImage& det = s->transport().images[0];
    const ExitAperture a = exitApertureFor(s->scene(), det.geometry());
    const NoTirJudge judge;
    double sigma[2];
    for (const bool parts : {false, true}) {
        RenderOptions o;
        o.raysPerPixel = 1024;
        o.photonsPerPass = 20000;
        o.initialRadiusMm = 5.0;
        o.partSamples = parts ? 16384 : 0;
        const Renderer renderer(ts, det, a, o, &judge);
        RenderState state(det.geometry(), o.initialRadiusMm, o.alpha, 1);
        for (int k = 1; k <= 8; ++k)
            state.add(renderer.runPass(k, state.radiusMm(), state.learned(), 0));
        const DetectorImage c = state.criterionComponent(0, RenderComponent::Caustic);
        const double flux = c.totalFlux();
        sigma[parts] = std::sqrt(c.totalVariance(state.passes()));
        std::cout << "parts " << parts << ": designed caustic " << flux << " +- " << sigma[parts]
                  << ", quadrature " << truth << "\n";
        EXPECT_LE(std::abs(flux - truth), 3.0 * sigma[parts] + 2e-3 * truth) << "parts " << parts;
    }
    EXPECT_LT(10.0 * sigma[1], sigma[0]);
}

}  // namespace
}  // namespace veil
