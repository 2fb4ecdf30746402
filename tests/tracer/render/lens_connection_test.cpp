// Light connected through the lens (tracer/render/lens_connection.h) against independent
// truth: forward Monte Carlo through the sequential model (traceSequential, its own
// intersections and Snell's law), counting the flux of the source's own rays that land
// within a small disk around the point, for a Sun beam off axis, a point source and an
// emitting window; the paraxial closed form on the axis; and the audit's test finds() on a
// photon's own path and on a neighbour's.

#include "tracer/render/lens_connection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "lensdata/glass_catalog.h"
#include "tests/tracer/render/box_mesh.h"
#include "tracer/runtime/rng.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/transport/interaction.h"

namespace veil {
namespace {

// A biconvex singlet (n 1.5, ideal antireflection, clear radius 12.5 mm, focal length about
// 100 mm), a white plate `plateMm` behind its front vertex (the chain the pilot finds: both
// faces, then the plate), and `sources`.
std::unique_ptr<PreparedScene> singletScene(const std::string& name, const std::string& sources,
                                            double plateMm = 61.0) {
    const std::string stem = ::testing::TempDir() + "veil_lens_connection_" + name;
    writeBox(stem + ".off", Vec3(-60.0, -60.0, plateMm), Vec3(60.0, 60.0, plateMm + 1.0));
    const std::string path = stem + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f,
            "%s]\n"
            "[[mesh]]\nname = \"plate\"\nfile = \"%s\"\nproperty = \"white\"\n"
            "[properties.white]\nscatter = { model = \"lambertian\", reflectance = 0.5 }\n"
            "%s"
            "[detector]\nsize_mm = [4.0, 4.0]\npixels = [1, 1]\n"
            "[[assign]]\nobjects = \"L1.*\"\nproperty = \"ideal_ar\"\n",
            singletSystem(99.0).c_str(), std::filesystem::path(stem + ".off").filename().c_str(),
            sources.c_str());
    fclose(f);
    return PreparedScene::read(path, GlassCatalog::builtIn());
}

// Three sources: the Sun 3 degrees off axis, a point 150 mm in front of the lens and 3 mm off
// axis, and a window emitting inside a 10 degree cone.
std::unique_ptr<PreparedScene> singletScene() {
    return singletScene("three",
                        "[[source]]\nname = \"sun\"\nkind = \"sun\"\nfield_deg = [0.0, 3.0]\n"
                        "[[source]]\nname = \"lamp\"\nkind = \"point\"\n"
                        "position_mm = [3.0, 0.0, -150.0]\n"
                        "[[source]]\nname = \"window\"\nkind = \"window\"\ncone_deg = 10.0\n");
}

// Where `ray` (leaving the source) crosses the plane z = zMm after the lens, by the sequential
// trace; false when it does not get through.
bool throughLens(const SequentialModel& m, const Ray& ray, double zMm, Vec3& at,
                 Vec3* dir = nullptr) {
    SequentialTraceOptions o;
    o.lastSurface = 2;
    const SequentialRayResult r = traceSequential(m, 0, ray, o);
    if (!r.ok()) return false;
    const double t = (zMm - r.ray.origin.z) / r.ray.direction.z;
    if (!(t > 0.0)) return false;
    at = r.ray.origin + t * r.ray.direction;
    if (dir) *dir = r.ray.direction;
    return true;
}

int objectId(const TransportView& ts, const std::string& name) {
    const SceneObject* o = ts.scene->find(name);
    EXPECT_TRUE(o) << name;
    return o ? o->id : -1;
}

struct Estimate {
    double mean = 0.0, sigma = 0.0;
};

// Forward Monte Carlo: the irradiance on the plane z = p.z within rho of p, from `rays` rays
// of source s.
Estimate forwardIrradiance(const PreparedScene& scene, size_t s, const Vec3& p, double rho,
                           uint64_t rays) {
    const Source& src = scene.transport().view.sources[s];
    double sum = 0.0, sum2 = 0.0;
    for (uint64_t i = 0; i < rays; ++i) {
        CounterRng rng(77, i);
        const EmittedRay e = src.emit(rng, rays);
        Vec3 at;
        if (!throughLens(scene.model(), e.ray, p.z, at)) continue;
        if (glm::length(at - p) > rho) continue;
        sum += e.flux;
        sum2 += e.flux * e.flux;
    }
    const double area = std::numbers::pi * rho * rho;
    const double n = static_cast<double>(rays);
    // The flux per ray is total / rays: the sum's variance is n var(x) for x = rays * flux.
    const double var = sum2 - sum * sum / n;
    return {sum / area, std::sqrt(std::max(var, 0.0)) / area};
}

// The connection: the mean over `samples` draws of its irradiance on the plane z = p.z, in
// parametrization `mode`.
Estimate connectedIrradiance(const LensConnector& lc, const PreparedScene& scene, size_t s,
                             const Vec3& p, int samples, int mode = 0) {
    double sum = 0.0, sum2 = 0.0;
    int found = 0;
    for (int i = 0; i < samples; ++i) {
        CounterRng rng(5, static_cast<uint64_t>(i));
        const double u1 = rng.uniform(), u2 = rng.uniform();
        LensConnector::Work work;
        const auto light =
            lc.connectAs(mode, s, 0, scene.model().wavelengthNm(0), 2, p, -1, u1, u2, work);
        if (!light) continue;
        ++found;
        const double e = light->value * std::abs(light->toLight.z);
        sum += e;
        sum2 += e * e;
    }
    const double n = static_cast<double>(samples);
    const double mean = sum / n;
    EXPECT_GT(found, 0);
    return {mean, std::sqrt(std::max(sum2 / n - mean * mean, 0.0) / n)};
}

// A point in the light of source s behind the lens: where the ray through entrance point
// (x, y) of the lens' front vertex plane crosses z = 60.
Vec3 litPoint(const PreparedScene& scene, size_t s, double x, double y) {
    const Source& src = scene.transport().view.sources[s];
    Ray ray;
    if (const auto* sun = std::get_if<SunSource>(&src.shape())) {
        const Vec3 d = sun->beam.direction;
        ray = {Vec3(x, y, 0.0) - 50.0 * d, d};
    } else if (const auto* pt = std::get_if<PointSource>(&src.shape())) {
        ray = {pt->positionMm, glm::normalize(Vec3(x, y, 0.0) - pt->positionMm)};
    } else {
        ray = {Vec3(x, y, -1.0), Vec3(0.0, 0.0, 1.0)};
    }
    Vec3 at;
    EXPECT_TRUE(throughLens(scene.model(), ray, 60.0, at));
    return at;
}

TEST(LensConnection, IrradianceAgreesWithForwardMonteCarloForEachSourceKind) {
    const auto scene = singletScene();
    const LensConnector lc(scene->transport().view);
    for (size_t s = 0; s < 3; ++s)
        EXPECT_EQ(lc.chains(s, objectId(scene->transport().view, "plate")), uint64_t{1} << 1);
    EXPECT_EQ(lc.parametrizations(0), 1);
    EXPECT_EQ(lc.parametrizations(1), 1);
    EXPECT_EQ(lc.parametrizations(2), 2);
    const double rho = 0.25;
    // The window in both ways: its direction drawn (mode 0) and its point drawn (mode 1).
    const struct {
        size_t source;
        int samples;
        double x, y;
        int mode;
    } cases[] = {{0, 400, 2.0, 3.0, 0},
                 {1, 1, -4.0, 1.0, 0},
                 {2, 40000, 1.0, -2.0, 0},
                 {2, 40000, 1.0, -2.0, 1}};
    for (const auto& c : cases) {
        const Vec3 p = litPoint(*scene, c.source, c.x, c.y);
        const Estimate fwd =
            forwardIrradiance(*scene, c.source, p, rho, c.source == 0 ? 8000000 : 4000000);
        const Estimate con = connectedIrradiance(lc, *scene, c.source, p, c.samples, c.mode);
        // The disk's own bias: the irradiance's curvature over rho, (rho / 10 mm)^2 of it.
        const double bias = 1e-3 * fwd.mean;
        EXPECT_LE(std::abs(con.mean - fwd.mean), 4.0 * std::hypot(con.sigma, fwd.sigma) + bias)
            << "source " << c.source << " mode " << c.mode << ": connected " << con.mean << " +- "
            << con.sigma << ", forward " << fwd.mean << " +- " << fwd.sigma;
        EXPECT_LT(fwd.sigma, 0.03 * fwd.mean) << "source " << c.source;
    }
}

// The pilot's choice between a window's two ways, where one clearly wins: on a plate just
// behind the lens (near its pupil) every direction of the cone reaches a point but only the
// window's points within a millimetre or so do, so the direction is drawn (0); on a plate
// near the focus, every point of the window reaches a point but only from directions within
// a fraction of a degree, so the point is drawn (1). A source with one way keeps it.
TEST(LensConnection, EachChainTakesTheWayThatFindsItsLight) {
    const std::string sources =
        "[[source]]\nname = \"window\"\nkind = \"window\"\ncone_deg = 10.0\n"
        "[[source]]\nname = \"sun\"\nkind = \"sun\"\nfield_deg = [0.0, 3.0]\n";
    for (const auto& [plateMm, expected] : {std::pair{8.0, 0}, std::pair{96.0, 1}}) {
        const auto scene = singletScene("choice" + std::to_string(expected), sources, plateMm);
        const LensConnector lc(scene->transport().view);
        const int plate = objectId(scene->transport().view, "plate");
        ASSERT_EQ(lc.chains(0, plate), uint64_t{1} << 1) << plateMm;
        EXPECT_EQ(lc.parametrization(0, plate, 2), expected) << "plate at " << plateMm << " mm";
        EXPECT_EQ(lc.parametrization(1, plate, 2), 0);
        // The way chosen finds the light at a point on the plate more often than the other.
        const Vec3 p(1.0, -2.0, plateMm);  // on the plate's face toward the lens
        int found[2] = {0, 0};
        for (int i = 0; i < 400; ++i) {
            CounterRng rng(9, static_cast<uint64_t>(i));
            const double u1 = rng.uniform(), u2 = rng.uniform();
            for (int m = 0; m < 2; ++m) {
                LensConnector::Work work;
                if (lc.connectAs(m, 0, 0, 550.0, 2, p, plate, u1, u2, work)) ++found[m];
            }
        }
        EXPECT_GT(found[expected], 2 * found[1 - expected])
            << "plate at " << plateMm << " mm: " << found[0] << " and " << found[1] << " found";
    }
}

TEST(LensConnection, OnTheAxisTheIrradianceIsTheParaxialOne) {
    // A collimated beam along the axis converges toward the rear focus: a paraxial ray at
    // height h leaves the lens (at its back vertex, z = 5) at height a h with slope c h (the
    // paraxial matrix, from before the front face to after the back face), so at z the beam's
    // cross-section is scaled by m = a + c (z - 5) and the irradiance on the axis is E / m^2:
    // exact on the axis, where the real rays' Jacobian is the paraxial one.
    const auto scene = singletScene(
        "axis", "[[source]]\nname = \"beam\"\nkind = \"collimated\"\nirradiance_w_mm2 = 2.0\n");
    const LensConnector lc(scene->transport().view);
    const ParaxialMatrix pm = paraxialMatrix(scene->model(), 0, 1, 2);
    for (const double z : {20.0, 40.0, 58.0}) {  // before the plate
        const double m = pm.a + pm.c * (z - 5.0);
        const double expected = 2.0 / (m * m);
        LensConnector::Work work;
        const auto light = lc.connect(0, 0, 550.0, 2, Vec3(0.0, 0.0, z), -1, 0.5, 0.5, work);
        ASSERT_TRUE(light) << z;
        EXPECT_NEAR(light->value, expected, 1e-6 * expected) << "z " << z;
        EXPECT_NEAR(light->toLight.z, -1.0, 1e-12);
        EXPECT_LT(work.rays, 200u);
    }
    // Beyond the lens' reach (outside the cone of light behind it) there is nothing to find.
    LensConnector::Work work;
    EXPECT_FALSE(lc.connect(0, 0, 550.0, 2, Vec3(40.0, 0.0, 60.0), -1, 0.5, 0.5, work));
}

TEST(LensConnection, FindsThePhotonsOwnPathAndNotItsNeighbours) {
    const auto scene = singletScene();
    const LensConnector lc(scene->transport().view);
    const Source& sun = scene->transport().view.sources[0];
    int checked = 0;
    for (uint64_t i = 0; i < 200; ++i) {
        CounterRng rng(3, i);
        const EmittedRay e = sun.emit(rng, 200);
        Vec3 at;
        if (!throughLens(scene->model(), e.ray, 60.0, at)) continue;
        LensConnector::Work work;
        // A ray within the finite differences' step of the rim has no Jacobian: connect()
        // misses it as finds() does, and the audit keeps it with the photons.
        const Vec3 front = e.ray.origin - e.ray.direction * (e.ray.origin.z / e.ray.direction.z);
        if (std::hypot(front.x, front.y) > 12.4) continue;
        ++checked;
        EXPECT_TRUE(lc.finds(0, 0, 550.0, 2, at, -1, e.ray, work)) << i;
        // A ray 0.05 mm beside it reaches another point: not the connection's path to `at`.
        const Ray beside{e.ray.origin + Vec3(0.05, 0.0, 0.0), e.ray.direction};
        EXPECT_FALSE(lc.finds(0, 0, 550.0, 2, at, -1, beside, work)) << i;
    }
    EXPECT_GT(checked, 150);
}

// The density of the connection's direction at the point (Light::pdfSr, from etendue) against
// finite differences of the map from the two uniforms to that direction: the uniforms have
// density 1 on the unit square, so the direction's density per steradian is 1 / |det| of
// d(direction) / d(u1, u2), the direction measured on the plane tangent to the unit sphere.
// For the Sun (uniform over its disk) and the window (the cosine law in its cone); a point
// source's single direction has no density (0).
TEST(LensConnection, DensityOfTheDirectionIsTheInverseJacobianOfTheUniforms) {
    const auto scene =
        singletScene("density",
                     "[[source]]\nname = \"sun\"\nkind = \"sun\"\nfield_deg = [0.0, 3.0]\n"
                     "[[source]]\nname = \"lamp\"\nkind = \"point\"\n"
                     "position_mm = [3.0, 0.0, -150.0]\n"
                     "[[source]]\nname = \"window\"\nkind = \"window\"\ncone_deg = 10.0\n"
                     "[[source]]\nname = \"disk\"\nkind = \"lambertian\"\n"
                     "position_mm = [0.0, 0.0, -30.0]\nnormal = [0.0, 0.0, 1.0]\n"
                     "radius_mm = 20.0\nflux = 1.0\n");
    const LensConnector lc(scene->transport().view);
    int total = 0;
    // (source, way): the window in both.
    for (const auto& [s, mode] : {std::pair{size_t{0}, 0}, std::pair{size_t{2}, 0},
                                  std::pair{size_t{2}, 1}, std::pair{size_t{3}, 0}}) {
        const Vec3 p = s == 3 ? Vec3(0.5, -0.3, 60.0) : litPoint(*scene, s, 1.5, -1.0);
        int checked = 0;
        for (const double u1 : {0.2, 0.5, 0.8})
            for (const double u2 : {0.1, 0.45, 0.7}) {
                LensConnector::Work work;
                const auto at = lc.connectAs(mode, s, 0, 550.0, 2, p, -1, u1, u2, work);
                if (!at) continue;  // no ray of the chain from that half reaches p
                const Vec3 w = at->toLight;
                const Vec3 e1 = glm::normalize(glm::cross(w, Vec3(1.0, 0.0, 0.0)));
                const Vec3 e2 = glm::cross(w, e1);
                const double h = 1e-4;
                Vec2 col[2];
                for (int k = 0; k < 2; ++k) {
                    Vec2 side[2];
                    for (int j = 0; j < 2; ++j) {
                        const double step = j == 0 ? h : -h;
                        const auto q =
                            lc.connectAs(mode, s, 0, 550.0, 2, p, -1, u1 + (k == 0 ? step : 0.0),
                                         u2 + (k == 1 ? step : 0.0), work);
                        ASSERT_TRUE(q);
                        // On the tangent plane at w (central projection).
                        const Vec3 t = q->toLight / glm::dot(q->toLight, w);
                        side[j] = Vec2(glm::dot(t, e1), glm::dot(t, e2));
                    }
                    col[k] = (side[0] - side[1]) / (2.0 * h);
                }
                const double det = std::abs(col[0].x * col[1].y - col[1].x * col[0].y);
                ASSERT_GT(det, 0.0);
                EXPECT_NEAR(at->pdfSr * det, 1.0, 2e-3)
                    << "source " << s << " mode " << mode << " u " << u1 << ", " << u2 << ": pdf "
                    << at->pdfSr << ", finite differences " << 1.0 / det;
                ++checked;
            }
        EXPECT_GE(checked, 2) << "source " << s << " mode " << mode;
        total += checked;
    }
    EXPECT_GE(total, 20);
    LensConnector::Work work;
    const auto point =
        lc.connect(1, 0, 550.0, 2, litPoint(*scene, 1, 1.0, 1.0), -1, 0.5, 0.5, work);
    ASSERT_TRUE(point);
    EXPECT_EQ(point->pdfSr, 0.0);
}

// The source's ray that reaches p along -w (w: from p toward the light) through the singlet,
// traced back from p (Snell's law is the same both ways), its origin on the plane the
// connection moves it on (a beam's start plane, a window's area) or on the emitting disk; none
// when the ray does not cross both faces.
std::optional<Ray> emittedThrough(const TransportView& ts, const Vec3& p, const Vec3& w,
                                  const Source& src) {
    Ray ray{p, w};
    int medium = 0, start = -1;
    for (const char* face : {"L1.back", "L1.front"}) {
        const auto hit = ts.scene->closestHit(ray, kInfinity, start, -1, medium);
        if (!hit || hit->object != ts.scene->find(face)->id) return std::nullopt;
        const Interaction in = interact(ts, *hit, ray.direction, 0, 550.0);
        int c = 0;
        while (c < in.count &&
               (in.children[c].scatter || in.children[c].event != EventType::Refract))
            ++c;
        if (c == in.count) return std::nullopt;
        ray = {hit->point, in.children[c].direction};
        medium = in.children[c].medium;
        start = hit->object;
    }
    Vec3 center, normal;
    if (const auto* sun = std::get_if<SunSource>(&src.shape())) {
        center = sun->beam.startCenterMm;
        normal = sun->beam.direction;
    } else {
        const AreaEmitter& a = std::holds_alternative<WindowSource>(src.shape())
                                   ? std::get<WindowSource>(src.shape()).area
                                   : std::get<LambertianSource>(src.shape()).area;
        center = a.frame.translation;
        normal = a.frame.toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    }
    const Vec3 e = -ray.direction;  // as emitted
    const double along = glm::dot(e, normal);
    if (!(std::abs(along) > 0.0)) return std::nullopt;
    const double back = glm::dot(ray.origin - center, normal) / along;
    return Ray{ray.origin - back * e, e};
}

// The Sun 3 degrees off axis, a window emitting inside a 10 degree cone and a wide Lambertian
// disk 30 mm before the lens (sources 0, 1, 2).
std::unique_ptr<PreparedScene> sunWindowDiskScene(const std::string& name) {
    return singletScene(name,
                        "[[source]]\nname = \"sun\"\nkind = \"sun\"\nfield_deg = [0.0, 3.0]\n"
                        "[[source]]\nname = \"window\"\nkind = \"window\"\ncone_deg = 10.0\n"
                        "[[source]]\nname = \"disk\"\nkind = \"lambertian\"\n"
                        "position_mm = [0.0, 0.0, -30.0]\nnormal = [0.0, 0.0, 1.0]\n"
                        "radius_mm = 20.0\nflux = 1.0\n");
}

// The directions connect() draws at a point follow its density: a chi-square test of their
// histogram against the density integrated over each cell, the density at any direction
// coming from found() for the source's own ray along it (emittedThrough), so that the two
// sides share nothing but the solve. For the Sun (the direction over its disk drawn, the point
// solved), a narrow-coned window (the same, and its other way: the point drawn, the direction
// solved) and a wide Lambertian disk (the point drawn, the direction solved).
TEST(LensConnection, DirectionsFollowTheirDensityByChiSquare) {
    const auto scene = sunWindowDiskScene("chi2");
    const TransportView& ts = scene->transport().view;
    const LensConnector lc(ts);
    constexpr int kSamples = 20000, kCells = 8, kSub = 16;
    for (const auto& [s, mode] : {std::pair{size_t{0}, 0}, std::pair{size_t{1}, 0},
                                  std::pair{size_t{1}, 1}, std::pair{size_t{2}, 0}}) {
        const Vec3 p = s == 2 ? Vec3(0.5, -0.3, 60.0) : litPoint(*scene, s, 1.5, -1.0);
        std::vector<Vec3> drawn;
        Vec3 mean(0.0);
        for (int i = 0; i < kSamples; ++i) {
            CounterRng rng(31 + s, static_cast<uint64_t>(i));
            const double u1 = rng.uniform(), u2 = rng.uniform();
            LensConnector::Work work;
            const auto c = lc.connectAs(mode, s, 0, 550.0, 2, p, -1, u1, u2, work);
            if (!c) continue;
            drawn.push_back(c->toLight);
            mean += c->toLight;
        }
        ASSERT_GT(drawn.size(), kSamples / 10) << "source " << s << " mode " << mode;
        // A tangent plane at the mean direction, and the box of the drawn directions on it.
        const Vec3 w0 = glm::normalize(mean);
        const Vec3 e1 = glm::normalize(glm::cross(w0, Vec3(1.0, 0.0, 0.0)));
        const Vec3 e2 = glm::cross(w0, e1);
        auto onPlane = [&](const Vec3& w) {
            const Vec3 t = w / glm::dot(w, w0);
            return Vec2(glm::dot(t, e1), glm::dot(t, e2));
        };
        Vec2 lo(1e300), hi(-1e300);
        for (const Vec3& w : drawn) {
            const Vec2 x = onPlane(w);
            lo = glm::min(lo, x);
            hi = glm::max(hi, x);
        }
        const Vec2 pad = 0.02 * (hi - lo);
        lo -= pad;
        hi += pad;
        const Vec2 cell = (hi - lo) / static_cast<double>(kCells);
        std::vector<double> observed(kCells * kCells, 0.0), expected(kCells * kCells, 0.0);
        for (const Vec3& w : drawn) {
            const Vec2 x = (onPlane(w) - lo) / cell;
            const int i = std::clamp(static_cast<int>(x.x), 0, kCells - 1);
            const int j = std::clamp(static_cast<int>(x.y), 0, kCells - 1);
            observed[static_cast<size_t>(j * kCells + i)] += 1.0;
        }
        // The density times the draws over each cell, by the midpoint rule on a kSub x kSub
        // grid: dOmega = da db / (1 + a^2 + b^2)^(3/2) on the tangent plane. (The density is
        // per draw: a draw whose ray misses the point is a direction of none.)
        const double n = kSamples;
        double integral = 0.0;
        for (int j = 0; j < kCells * kSub; ++j)
            for (int i = 0; i < kCells * kSub; ++i) {
                const double a = lo.x + (i + 0.5) * cell.x / kSub;
                const double b = lo.y + (j + 0.5) * cell.y / kSub;
                const Vec3 w = glm::normalize(w0 + a * e1 + b * e2);
                const auto emitted = emittedThrough(ts, p, w, ts.sources[s]);
                if (!emitted) continue;
                LensConnector::Work work;
                const auto f = lc.foundAs(mode, s, 0, 550.0, 2, p, -1, *emitted, work);
                if (!f) continue;
                const double dOmega =
                    cell.x * cell.y / (kSub * kSub) / std::pow(1.0 + a * a + b * b, 1.5);
                const double mass = f->pdfSr * dOmega;
                integral += mass;
                expected[static_cast<size_t>((j / kSub) * kCells + i / kSub)] += n * mass;
            }
        // The density integrates to the share of the draws that reach the point.
        const double reached = static_cast<double>(drawn.size()) / kSamples;
        EXPECT_NEAR(integral, reached, 0.01 * reached + 3.0 * std::sqrt(reached / kSamples))
            << "source " << s << " mode " << mode;
        // Cells expecting fewer than 20 are pooled.
        double chi2 = 0.0, poolO = 0.0, poolE = 0.0;
        int bins = 0;
        for (size_t c = 0; c < expected.size(); ++c) {
            if (expected[c] < 20.0) {
                poolO += observed[c];
                poolE += expected[c];
                continue;
            }
            chi2 += (observed[c] - expected[c]) * (observed[c] - expected[c]) / expected[c];
            ++bins;
        }
        if (poolE > 0.0) {
            chi2 += (poolO - poolE) * (poolO - poolE) / std::max(poolE, 1.0);
            ++bins;
        }
        // Wilson and Hilferty: chi2 / k with k = bins - 1 degrees of freedom is about normal
        // after a cube root; 4 sigma is a p-value of 3e-5.
        const double k = bins - 1.0;
        const double z =
            (std::cbrt(chi2 / k) - (1.0 - 2.0 / (9.0 * k))) / std::sqrt(2.0 / (9.0 * k));
        std::cout << "source " << s << " mode " << mode << ": chi2 " << chi2 << " over " << k
                  << " degrees of freedom (z " << z << "), density integral " << integral << "\n";
        EXPECT_GE(bins, 20) << "source " << s << " mode " << mode;
        EXPECT_LT(z, 4.0) << "source " << s << " mode " << mode << ": chi2 " << chi2 << " with "
                          << k << " dof";
    }
}

// At a followed narrow lobe (tracer/render/backward.cpp), the connection's light is weighed
// p_c / (p_c + p_lobe), and a source that the lobe's own direction reaches through the same
// chain p_lobe / (p_lobe + p_c'), p_c' from found() for that path. The two weights sum to one
// only if found() gives the connection's own density for the connection's own path: checked
// on every draw, for the Sun, a window both ways and a wide Lambertian disk, the path rebuilt
// by the independent trace back from the point (emittedThrough).
TEST(LensConnection, MisWeightsOfTheConnectionAndTheLobeSumToOne) {
    const auto scene = sunWindowDiskScene("mis");
    const TransportView& ts = scene->transport().view;
    const LensConnector lc(ts);
    for (const auto& [s, mode] : {std::pair{size_t{0}, 0}, std::pair{size_t{1}, 0},
                                  std::pair{size_t{1}, 1}, std::pair{size_t{2}, 0}}) {
        const Vec3 p = s == 2 ? Vec3(0.5, -0.3, 60.0) : litPoint(*scene, s, 1.5, -1.0);
        int checked = 0;
        for (int i = 0; i < 500; ++i) {
            CounterRng rng(61 + s, static_cast<uint64_t>(i));
            const double u1 = rng.uniform(), u2 = rng.uniform();
            LensConnector::Work work;
            const auto c = lc.connectAs(mode, s, 0, 550.0, 2, p, -1, u1, u2, work);
            if (!c) continue;
            ASSERT_GT(c->pdfSr, 0.0);
            const auto emitted = emittedThrough(ts, p, c->toLight, ts.sources[s]);
            ASSERT_TRUE(emitted) << "source " << s << ": the connection's path does not trace back";
            const auto f = lc.foundAs(mode, s, 0, 550.0, 2, p, -1, *emitted, work);
            ASSERT_TRUE(f) << "source " << s << " mode " << mode << ": its own path not found";
            EXPECT_NEAR(f->pdfSr, c->pdfSr, 1e-6 * c->pdfSr) << "source " << s << " mode " << mode;
            for (const double lobe : {1e-3 * c->pdfSr, c->pdfSr, 1e3 * c->pdfSr})
                EXPECT_NEAR(c->pdfSr / (c->pdfSr + lobe) + lobe / (lobe + f->pdfSr), 1.0, 1e-6);
            ++checked;
        }
        EXPECT_GT(checked, 50) << "source " << s << " mode " << mode;
    }
}

// Ghost routes (the header comment's "Ghost routes") against the closed form. A collimated
// beam 10 degrees off axis (irradiance E) meets a bare plane-parallel plate (n 1.5); a white
// plate 150 mm in front of it, beside the incoming beam, is lit only by the plate's
// reflections. A plane face keeps a collimated beam's cross-section, so the irradiance
// perpendicular to the ray is E R (the front face's reflection) and E (1 - R) R (1 - R) (in
// through the front face, reflected by the back face, out through the front face; inside, the
// reflectance at the refracted angle equals R by Stokes' relations), with R the unpolarized
// Fresnel reflectance at 10 degrees.
TEST(LensConnection, GhostRoutesAgreeWithTheFresnelClosedForm) {
    const std::string stem = ::testing::TempDir() + "veil_lens_connection_ghost";
    writeBox(stem + ".off", Vec3(-30.0, 20.0, -151.0), Vec3(30.0, 60.0, -150.0));
    const std::string path = stem + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fprintf(f,
            "[system]\nwavelengths_nm = [550.0]\naperture = { epd_mm = 20.0 }\n"
            "fields_deg = [0.0]\nsurfaces = [\n"
            "  { r = inf, t = 5.0, glass = { nd = 1.5, vd = 0.0 }, sd = 12.5, stop = true },\n"
            "  { r = inf, t = 50.0, sd = 12.5 },\n]\n"
            "[[mesh]]\nname = \"wall\"\nfile = \"%s\"\nproperty = \"white\"\n"
            "[properties.white]\nscatter = { model = \"lambertian\", reflectance = 0.5 }\n"
            "[[source]]\nname = \"beam\"\nkind = \"collimated\"\nfield_deg = 10.0\n"
            "irradiance_w_mm2 = 2.0\n"
            "[detector]\nsize_mm = [4.0, 4.0]\npixels = [1, 1]\n",
            std::filesystem::path(stem + ".off").filename().c_str());
    fclose(f);
    const auto scene = PreparedScene::read(path, GlassCatalog::builtIn());
    const TransportView& ts = scene->transport().view;
    const LensConnector lc(ts);
    const int wall = objectId(ts, "wall");
    const int front = objectId(ts, "L1.front"), back = objectId(ts, "L1.back");

    const double n = 1.5, ci = std::cos(10.0 * std::numbers::pi / 180.0);
    const double ct = std::sqrt(1.0 - (1.0 - ci * ci) / (n * n));
    const double rs = std::pow((ci - n * ct) / (ci + n * ct), 2.0);
    const double rp = std::pow((n * ci - ct) / (n * ci + ct), 2.0);
    const double r = 0.5 * (rs + rp);

    // The two routes, as a photon's events reach them.
    const int a = lc.advance(0, front, EventType::FresnelReflect);
    const int b = lc.advance(
        lc.advance(lc.advance(0, front, EventType::Refract), back, EventType::FresnelReflect),
        front, EventType::Refract);
    ASSERT_GE(a, LensConnector::kGhostBase);
    ASSERT_GE(b, LensConnector::kGhostBase);
    EXPECT_TRUE(lc.hasChain(0, wall, a));
    EXPECT_TRUE(lc.hasChain(0, wall, b));
    EXPECT_FALSE(lc.hasChain(0, wall, 2));  // no designed light reaches the wall
    // Two reflections send the light on through the plate, away from the wall.
    EXPECT_EQ(lc.ghostChains(0, wall).size(), 2u);

    for (const auto& [key, expected] :
         {std::pair{a, 2.0 * r}, std::pair{b, 2.0 * (1 - r) * r * (1 - r)}}) {
        for (const double y : {24.0, 27.0, 31.0}) {
            const Vec3 p(1.5, y, -150.0);
            LensConnector::Work work;
            std::vector<PathEvent> events;
            const auto light = lc.connect(0, 0, 550.0, key, p, wall, 0.5, 0.5, work, &events);
            ASSERT_TRUE(light) << key << " y " << y;
            EXPECT_NEAR(light->value, expected, 1e-6 * expected) << key << " y " << y;
            // It arrives along the reflected beam's direction.
            EXPECT_NEAR(light->toLight.z, ci, 1e-9);
            // The route's events, in the order light travels them.
            ASSERT_EQ(events.size(), key == a ? 1u : 3u);
            EXPECT_EQ(events[key == a ? 0 : 1].type, EventType::FresnelReflect);
        }
    }
    // Outside the reflected beam there is nothing to find.
    LensConnector::Work work;
    EXPECT_FALSE(lc.connect(0, 0, 550.0, a, Vec3(0.0, 58.0, -150.0), wall, 0.5, 0.5, work));
}

}  // namespace
}  // namespace veil
