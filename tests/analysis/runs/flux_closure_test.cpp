// Flux closure that can see lost light. The budget's imbalance is an identity if whatever the
// transport loses is booked as absorbed; these scenes absorb nothing (dispersion-free model
// glass without absorption, uncoated faces, ground-glass butt ends that scatter half and
// transmit half, no mechanics), so absorbed flux must be 0 and every watt must reach the
// detector, escape, or be culled by an explicit rule. A refraction branch the transport
// forgot, a channel booked twice or a scattered ray without a direction breaks one of the
// equalities below.

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "tests/analysis/prepared_scene.h"
#include "tracer/render/render.h"

namespace veil {
namespace {

using test::prepare;
using test::Prepared;
using test::writeScene;

// A thick biconvex singlet and a cemented doublet of model glasses (no catalog absorption)
// in air, a free detector (its object is its pixel rectangle: the default one on the image
// surface is a disc around the rectangle, whose corners absorb) in front of the image
// plane, a collimated beam at 5 degrees overfilling the front face
// so the butt ends and flats are hit too.
std::string losslessScene(double ndCrown, double ndFlint) {
    const std::string crown = "{ nd = " + std::to_string(ndCrown) + ", vd = 0.0 }";
    const std::string flint = "{ nd = " + std::to_string(ndFlint) + ", vd = 0.0 }";
    return R"([system]
name = "lossless"
wavelengths_nm = [587.5618]
aperture = { f_number = 4.0 }
fields_deg = [0.0, 5.0]
surfaces = [
  { stop = true, t = 5.0, sd = 12.5 },
  { r = 60.0, t = 6.0, glass = )" +
           crown + R"(, sd = 13.0, mech_sd = 14.0 },
  { r = -60.0, t = 10.0, sd = 13.0, mech_sd = 14.0 },
  { r = 50.0, t = 7.0, glass = )" +
           crown + R"(, sd = 12.0, mech_sd = 13.0 },
  { r = -40.0, t = 3.0, glass = )" +
           flint + R"(, sd = 12.0, mech_sd = 13.0 },
  { r = -200.0, t = 30.0, sd = 12.0, mech_sd = 13.0 },
]
[[source]]
name = "beam"
kind = "collimated"
field_deg = 5.0
margin_mm = 2.0
[detector]
name = "plane"
z_mm = 60.0
size_mm = [80.0, 80.0]
pixels = [16, 16]
)";
}

FluxBudget traceLossless(double ndCrown, double ndFlint, TransportOptions::Mode mode,
                         uint64_t rays) {
    Prepared r = prepare(writeScene("lossless", losslessScene(ndCrown, ndFlint)));
    TransportOptions o;
    o.mode = mode;
    o.minRelativeFlux = 1e-9;
    o.maxSplitDepth = 200;
    o.seed = 11;
    return traceNonsequential(r.trace.view, r.trace.images, rays, o).budget;
}

TEST(FluxClosure, LosslessSceneAbsorbsNothingInSplitMode) {
    const FluxBudget b = traceLossless(1.5168, 1.7552, TransportOptions::Mode::Split, 400);
    ASSERT_GT(b.emitted, 0.0);
    // The edges scatter, the faces split: many branches, all of them accounted for.
    EXPECT_GT(b.branches, 20u * b.rays);
    EXPECT_LT(b.absorbed(), 1e-12 * b.emitted) << b;
    EXPECT_LT(std::abs(b.imbalance()), 1e-12 * b.emitted) << b;
    // No channel without a direction in this scene: every refraction the Fresnel channels
    // count has a Snell direction (both use the same TIR test).
    EXPECT_EQ(b.dropped, 0.0) << b;
    EXPECT_EQ(b.droppedBranches[0] + b.droppedBranches[1], 0u) << b;
    // What was culled is only the 1e-9 tail and the depth limit: the rest reached the
    // detector or left the scene.
    EXPECT_LT(b.culled, 1e-3 * b.emitted) << b;
    EXPECT_NEAR(b.detected + b.escaped, b.emitted, 1e-3 * b.emitted) << b;
    EXPECT_GT(b.detected, 0.3 * b.emitted) << b;
}

TEST(FluxClosure, LosslessSceneAbsorbsNothingInRandomMode) {
    const FluxBudget b = traceLossless(1.5168, 1.7552, TransportOptions::Mode::Random, 3000);
    EXPECT_LT(b.absorbed(), 1e-12 * b.emitted) << b;
    EXPECT_LT(std::abs(b.imbalance()), 1e-12 * b.emitted) << b;
    EXPECT_EQ(b.dropped, 0.0) << b;
    EXPECT_NEAR(b.detected + b.escaped + b.culled, b.emitted, 1e-12 * b.emitted) << b;
}

// A high-index crown (n = 2.4) makes total internal reflection common inside the glass and at
// grazing exits: still nothing absorbed and nothing dropped.
TEST(FluxClosure, TotalInternalReflectionLosesNothing) {
    const FluxBudget b = traceLossless(2.4, 1.9, TransportOptions::Mode::Split, 300);
    EXPECT_LT(b.absorbed(), 1e-12 * b.emitted) << b;
    EXPECT_LT(std::abs(b.imbalance()), 1e-12 * b.emitted) << b;
    EXPECT_EQ(b.dropped, 0.0) << b;
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// An image inside a medium: a plate of n = 1.5, then a water block (n = 1.333) whose glass
// reaches the image, as an immersion objective's specimen side. The block's solid ends in
// an absorbing face just behind the image, so the sensor lies inside the water and meets the
// light there. The truth: a normal collimated beam through two lossless elements, traced
// incoherently to all orders, reaches the water with T_p T_w / (1 - R_p R_w), R_p = 1 - T_p,
// T_p = (1 - R) / (1 + R) the plate's, R = ((1.5 - 1) / 2.5)^2, T_w = 1 - R_w the water
// face's, R_w = ((1.333 - 1) / 2.333)^2; nothing returns from inside the water.
TEST(FluxClosure, AnImmersedImageMeetsTheLightInsideTheMedium) {
    Prepared r = test::prepare(writeScene("immersed", R"([system]
name = "immersed"
wavelengths_nm = [587.5618]
aperture = { epd_mm = 8.0 }
fields_deg = [0.0]
surfaces = [
  { stop = true, t = 5.0, sd = 4.0 },
  { r = inf, t = 3.0, glass = { nd = 1.5, vd = 0.0 }, sd = 10.0 },
  { r = inf, t = 4.0, sd = 10.0 },
  { r = inf, t = 2.0, glass = { nd = 1.333, vd = 0.0 }, sd = 10.0 },
  { image = true, sd = 10.0 },
]
[[source]]
name = "beam"
kind = "collimated"
field_deg = 0.0
)"));
    const SceneObject* end = r.setup->scene.find("L2.back");
    ASSERT_NE(end, nullptr);
    EXPECT_EQ(end->sequentialSurface, -1);
    EXPECT_EQ(end->property, "absorber");
    const SceneObject* sensor = r.setup->scene.find("sensor");
    ASSERT_NE(sensor, nullptr);
    EXPECT_NEAR(sensor->frame.translation.z, 14.0, 1e-12);  // on the image, inside the water
    bool said = false;
    for (const ImportNote& n : r.setup->notes)
        said |=
            n.message.find("the image lies inside the glass after L2.front") != std::string::npos;
    EXPECT_TRUE(said);

    TransportOptions o;
    o.mode = TransportOptions::Mode::Split;
    o.minRelativeFlux = 1e-12;
    o.maxSplitDepth = 200;
    o.seed = 3;
    const FluxBudget b = traceNonsequential(r.trace.view, r.trace.images, 200, o).budget;
    const double R = std::pow(0.5 / 2.5, 2), Rw = std::pow(0.333 / 2.333, 2);
    const double Tp = (1.0 - R) / (1.0 + R), Tw = 1.0 - Rw;
    const double truth = Tp * Tw / (1.0 - (1.0 - Tp) * Rw);
    EXPECT_NEAR(b.detected / b.emitted, truth, 1e-9) << b;
    EXPECT_LT(std::abs(b.imbalance()), 1e-12 * b.emitted) << b;

    // The renderer, whose pixel rays start in air, says why it cannot take this detector.
    try {
        exitApertureFor(r.setup->scene, r.setup->detectors.at(0));
        ADD_FAILURE() << "the renderer took a detector inside the water";
    } catch (const ModelError& e) {
        EXPECT_NE(std::string(e.what()).find("lies inside the glass of L2"), std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace veil
