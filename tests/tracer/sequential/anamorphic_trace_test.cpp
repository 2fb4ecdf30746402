// Sequential trace through toroidal and biconic surfaces, against independent truth: a
// cylinder lens is a spherical lens in y and a plate in x, exactly, ray by ray; a biconic
// with equal sections is the conic lens and a toroid swept about its own centre of curvature
// is the spherical one; and the x-z section's paraxial data are a thin lens's by the
// lensmaker's equation.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tests/test_lenses.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {
namespace {

using test::finishLens;
using test::startLens;
using test::surface;

const GlassCatalog kNoCatalog;
const Material kGlass = Material::model(1.5, 0.0);

// A singlet: front surface `front`, a flat back, 5 mm thick, then `image` mm to the image.
Prescription singlet(const Surface& front, double image) {
    Prescription p = startLens(kInfinity, 10.0);
    Surface f = front;
    f.thicknessMm = 5.0;
    f.material = kGlass;
    f.stop = true;
    p.surfaces.push_back(f);
    p.surfaces.push_back(surface(0.0, image));
    finishLens(p);
    return p;
}

double efl(const Prescription& p) {
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    return -1.0 / paraxialMatrix(m, 0, 1, m.imageIndex() - 1).c;
}

Surface toroid(double r, double xr) {
    Surface s = surface(r, 0.0);
    s.anamorphic = Anamorphic{Anamorphic::Kind::Toroidal, std::isinf(xr) ? 0.0 : 1.0 / xr, 0.0};
    return s;
}

// A cylinder surface z = f(y) has normals with no x part: a ray parallel to the axis keeps
// its x and bends in y exactly as the spherical lens's ray at the same y.
TEST(AnamorphicTrace, CylinderLensIsASphereInYAndAPlateInX) {
    const double r = 50.0;
    const double bfl = r / 0.5 - 5.0 / 1.5;  // plano-convex, curved side first
    const SequentialModel cyl =
        SequentialModel::build(singlet(toroid(r, kInfinity), bfl), kNoCatalog);
    const SequentialModel sph = SequentialModel::build(singlet(surface(r, 0.0), bfl), kNoCatalog);
    EXPECT_NEAR(efl(singlet(toroid(r, kInfinity), bfl)), 100.0, 1e-12);
    EXPECT_TRUE(std::isinf(efl(singlet(toroid(r, kInfinity), bfl).xSection())) ||
                std::abs(efl(singlet(toroid(r, kInfinity), bfl).xSection())) > 1e15);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-3.5, 3.5);  // inside the 5 mm stop
    for (int i = 0; i < 500; ++i) {
        const double x0 = u(rng), y0 = u(rng);
        const auto a = traceSequential(cyl, 0, Ray{Vec3(x0, y0, -10.0), Vec3(0, 0, 1)});
        const auto b = traceSequential(sph, 0, Ray{Vec3(0.0, y0, -10.0), Vec3(0, 0, 1)});
        ASSERT_TRUE(a.ok() && b.ok()) << x0 << ", " << y0;
        EXPECT_NEAR(a.ray.origin.x, x0, 1e-12);
        EXPECT_NEAR(a.ray.origin.y, b.ray.origin.y, 1e-11);
        EXPECT_NEAR(a.ray.direction.x, 0.0, 1e-15);
    }
    // Near the axis the y fan meets at the paraxial focus.
    const auto near = traceSequential(cyl, 0, Ray{Vec3(2.0, 1e-3, -10.0), Vec3(0, 0, 1)});
    ASSERT_TRUE(near.ok());
    EXPECT_NEAR(near.ray.origin.y, 0.0, 1e-9);
}

// A cylinder with power in x only (y radius infinite, radius of rotation 60 mm): the x-z
// section is the plano-convex lens of radius 60, the y-z section a plate.
TEST(AnamorphicTrace, XSectionFirstOrderIsTheLensmakers) {
    const Prescription p = singlet(toroid(kInfinity, 60.0), 100.0);
    EXPECT_GT(std::abs(efl(p)), 1e15);
    EXPECT_NEAR(efl(p.xSection()), 60.0 / 0.5, 1e-12);
    // A biconic: x radius 40, conic irrelevant paraxially.
    Surface b = surface(-80.0, 0.0);
    b.anamorphic = Anamorphic{Anamorphic::Kind::Biconic, 1.0 / 40.0, -1.0};
    const Prescription q = singlet(b, 100.0);
    EXPECT_NEAR(efl(q), -80.0 / 0.5, 1e-12);
    EXPECT_NEAR(efl(q.xSection()), 40.0 / 0.5, 1e-12);
    // And the real x fan of the cylinder meets at its paraxial focus near the axis.
    const double bfl = 120.0 - 5.0 / 1.5;
    const SequentialModel m =
        SequentialModel::build(singlet(toroid(kInfinity, 60.0), bfl), kNoCatalog);
    const auto near = traceSequential(m, 0, Ray{Vec3(1e-3, 3.0, -10.0), Vec3(0, 0, 1)});
    ASSERT_TRUE(near.ok());
    EXPECT_NEAR(near.ray.origin.x, 0.0, 1e-9);
    EXPECT_NEAR(near.ray.origin.y, 3.0, 1e-12);
}

// Equal sections: the biconic is the conic, the toroid (radius of rotation = profile radius)
// the sphere; oblique rays through the whole system land where the rotational lens's do.
TEST(AnamorphicTrace, ReducesToTheRotationalLens) {
    Surface conic = surface(45.0, 0.0);
    conic.conic = -0.8;
    Surface biconic = conic;
    biconic.anamorphic = Anamorphic{Anamorphic::Kind::Biconic, 1.0 / 45.0, -0.8};
    Surface sphere = surface(45.0, 0.0);
    const Surface torus = toroid(45.0, 45.0);
    const std::pair<Surface, Surface> pairs[] = {{biconic, conic}, {torus, sphere}};
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u(-4.5, 4.5), a(-0.1, 0.1);
    for (const auto& [ana, rot] : pairs) {
        const SequentialModel ma = SequentialModel::build(singlet(ana, 80.0), kNoCatalog);
        const SequentialModel mr = SequentialModel::build(singlet(rot, 80.0), kNoCatalog);
        for (int i = 0; i < 300; ++i) {
            const Ray ray{Vec3(u(rng), u(rng), -10.0), glm::normalize(Vec3(a(rng), a(rng), 1.0))};
            const auto ra = traceSequential(ma, 0, ray), rr = traceSequential(mr, 0, ray);
            ASSERT_EQ(ra.status, rr.status);
            if (!ra.ok()) continue;
            EXPECT_NEAR(glm::length(ra.ray.origin - rr.ray.origin), 0.0, 1e-10);
            EXPECT_NEAR(glm::length(ra.ray.direction - rr.ray.direction), 0.0, 1e-12);
        }
    }
}

TEST(AnamorphicTrace, InvalidCombinationsAreModelErrors) {
    Surface b = surface(50.0, 0.0);
    b.anamorphic = Anamorphic{Anamorphic::Kind::Biconic, 0.02, 0.0};
    b.asphere[1] = 1e-6;
    EXPECT_THROW(singlet(b, 50.0), ModelError);
    Surface t = toroid(50.0, 40.0);
    t.anamorphic->xConic = -1.0;
    EXPECT_THROW(singlet(t, 50.0), ModelError);
    Surface q = toroid(50.0, 40.0);
    q.oddAsphere[0] = 1e-5;
    EXPECT_THROW(singlet(q, 50.0), ModelError);
}

}  // namespace
}  // namespace veil
