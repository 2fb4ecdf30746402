// The scatter guide (tracer/render/scatter_guide.h) against its definition: places map to the
// grid's cells (hashed beyond kMaxSlots), the guide draws each direction cell with its learned
// share (chi-square) and gives the density of what it draws, and a scatter drawn through it,
// weighted by the surface's density over the mixture's, keeps every integral of the surface's
// own scatter: the flux it carries and the part of it inside a cone, against closed forms
// (Lambertian) and the surface's own sampling (a Gaussian lobe), by z-score.

#include "tracer/render/scatter_guide.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "tracer/runtime/rng.h"
#include "tracer/surfaces/optical_property.h"

namespace veil {
namespace {

constexpr int kCells = ScatterGuide::kCellCount;

Bounds3 box(const Vec3& lo, const Vec3& hi) {
    Bounds3 b;
    b.extend(lo);
    b.extend(hi);
    return b;
}

TEST(ScatterGuide, PlacesFallInTheGridsCells) {
    // 160 x 20 x 10 mm: cubes of 10 mm (16 along the longest side), 16 x 2 x 1 of them.
    const ScatterGuide guide(box(Vec3(0.0), Vec3(160.0, 20.0, 10.0)));
    EXPECT_EQ(guide.slots(), size_t{32});
    EXPECT_EQ(guide.bins(), size_t{32} * (kCells + 3) + 2);  // cells, then yields, then totals
    EXPECT_EQ(guide.slot(Vec3(5.0, 5.0, 5.0)), 0);
    EXPECT_EQ(guide.slot(Vec3(15.0, 5.0, 5.0)), 1);
    EXPECT_EQ(guide.slot(Vec3(5.0, 15.0, 5.0)), 16);
    EXPECT_EQ(guide.slot(Vec3(159.9, 19.9, 9.9)), 31);
    // Outside the bounds (and NaN): the nearest boundary cell.
    EXPECT_EQ(guide.slot(Vec3(-50.0, 5.0, 5.0)), 0);
    EXPECT_EQ(guide.slot(Vec3(1e9, 1e9, 1e9)), 31);
    EXPECT_EQ(guide.slot(Vec3(std::nan(""), 5.0, 5.0)), 0);
    // A cube of 16^3 cells is more than kMaxSlots: hashed into them.
    const ScatterGuide big(box(Vec3(-500.0), Vec3(500.0)));
    EXPECT_EQ(big.slots(), size_t{ScatterGuide::kMaxSlots});
    CounterRng rng(3, 0);
    for (int i = 0; i < 10000; ++i) {
        const Vec3 p(rng.uniform() * 1200.0 - 600.0, rng.uniform() * 1200.0 - 600.0,
                     rng.uniform() * 1200.0 - 600.0);
        const int s = big.slot(p);
        ASSERT_GE(s, 0);
        ASSERT_LT(s, ScatterGuide::kMaxSlots);
    }
    EXPECT_THROW(ScatterGuide(Bounds3{}), std::invalid_argument);
}

TEST(ScatterGuide, CellsOfDirections) {
    EXPECT_EQ(ScatterGuide::cellOf(Vec3(1.0, 0.0, -1.0 + 1e-12)), 0);
    EXPECT_EQ(ScatterGuide::cellOf(Vec3(0.0, 0.0, 1.0)), kCells - ScatterGuide::kSectors);
    EXPECT_EQ(ScatterGuide::cellOf(Vec3(1.0, -1e-9, 0.0)),
              (ScatterGuide::kBands / 2) * ScatterGuide::kSectors + ScatterGuide::kSectors - 1);
}

// A guide over a 16 x 1 x 1 mm box (16 slots) that learned light in slot 0's three cells: most
// in one near the pole +z, some at the equator, some on the -z side.
Bounds3 row() { return box(Vec3(0.0), Vec3(16.0, 1.0, 1.0)); }
ScatterGuide learnedGuide(double g, int& pole, int& equator, int& below) {
    ScatterGuide guide(row());
    EXPECT_EQ(guide.slots(), size_t{16});
    std::vector<double> learned(guide.bins(), 0.0);
    pole = ScatterGuide::cellOf(glm::normalize(Vec3(0.3, 0.2, 0.95)));
    equator = ScatterGuide::cellOf(glm::normalize(Vec3(1.0, 0.4, 0.05)));
    below = ScatterGuide::cellOf(glm::normalize(Vec3(-0.2, 0.5, -0.8)));
    learned[guide.bin(0, pole)] = 6.0;
    learned[guide.bin(0, equator)] = 3.0;
    learned[guide.bin(0, below)] = 1.0;
    guide.prepare(learned, g);
    return guide;
}

TEST(ScatterGuide, DrawsEachCellWithItsShareAndGivesItsDensity) {
    int pole = 0, equator = 0, below = 0;
    const ScatterGuide guide = learnedGuide(0.5, pole, equator, below);
    ASSERT_TRUE(guide.guides(0));
    const int n = 100000;
    std::vector<double> counts(kCells, 0.0);
    CounterRng rng(5, 0);
    for (int i = 0; i < n; ++i) {
        const Vec3 w = guide.sample(0, rng.uniform(), rng.uniform(), rng.uniform());
        ASSERT_NEAR(glm::length(w), 1.0, 1e-12);
        counts[static_cast<size_t>(ScatterGuide::cellOf(w))] += 1.0;
    }
    // Chi-square over the three learned cells (2 degrees of freedom: 13.8 at p = 0.001); no
    // other cell is drawn.
    const double share[3] = {0.6, 0.3, 0.1};
    const int cell[3] = {pole, equator, below};
    double chi2 = 0.0, drawn = 0.0;
    for (int k = 0; k < 3; ++k) {
        const double e = share[k] * n;
        chi2 += (counts[static_cast<size_t>(cell[k])] - e) *
                (counts[static_cast<size_t>(cell[k])] - e) / e;
        drawn += counts[static_cast<size_t>(cell[k])];
    }
    EXPECT_LT(chi2, 13.8);
    EXPECT_EQ(drawn, n);
    // The density: the cell's share over the cell's solid angle (4 pi / kCells), 0 elsewhere;
    // over the sphere it integrates to 1.
    EXPECT_NEAR(guide.pdf(0, glm::normalize(Vec3(0.3, 0.2, 0.95))),
                0.6 * kCells / (4.0 * std::numbers::pi), 1e-12);
    EXPECT_EQ(guide.pdf(0, Vec3(0.0, 0.0, -1.0)), 0.0);
    double integral = 0.0;
    const int m = 400000;
    for (int i = 0; i < m; ++i) {
        const double z = 2.0 * rng.uniform() - 1.0, phi = 2.0 * std::numbers::pi * rng.uniform();
        const double r = std::sqrt(1.0 - z * z);
        integral += guide.pdf(0, Vec3(r * std::cos(phi), r * std::sin(phi), z)) * 4.0 *
                    std::numbers::pi / m;
    }
    EXPECT_NEAR(integral, 1.0, 0.02);
    // Slot 1 learned nothing: not guided. Nothing learned, or a fraction of 0: nothing guided.
    EXPECT_FALSE(guide.guides(1));
    EXPECT_EQ(guide.pdf(1, Vec3(0.0, 0.0, 1.0)), 0.0);
    ScatterGuide none(row());
    none.prepare(std::vector<double>(none.bins(), 0.0), 0.5);
    EXPECT_FALSE(none.guides(0));
    std::vector<double> learned(none.bins(), 1.0);
    none.prepare(learned, 0.0);
    EXPECT_FALSE(none.guides(0));
    EXPECT_THROW(none.prepare(learned, 1.0), std::invalid_argument);
    EXPECT_THROW(none.prepare(std::vector<double>(3, 1.0), 0.5), std::invalid_argument);
}

// The scatter of a ray arriving at 30 degrees on a surface facing +z (a reflecting channel
// only), as interact() gives it.
Interaction scatterAt(const OpticalProperty& p) {
    Interaction in;
    in.property = &p;
    in.context.direction = glm::normalize(Vec3(std::sin(0.5236), 0.0, -std::cos(0.5236)));
    in.context.normal = Vec3(0.0, 0.0, 1.0);
    in.context.opaque = true;
    in.count = 1;
    in.children[0].scatter = true;
    in.children[0].share = 1.0;
    in.children[0].event = EventType::ScatterReflect;
    in.total = 1.0;
    return in;
}

// Mean and standard error of the weight, and of the weight inside a cone of half angle
// `coneRad` about `axis`, over n drawn scatters.
struct Estimate {
    double weight = 0.0, weightError = 0.0, cone = 0.0, coneError = 0.0;
    int died = 0;
};
Estimate estimate(const ScatterGuide& guide, const Interaction& in, const Vec3& axis,
                  double coneRad, int n, uint64_t seed) {
    double s1 = 0.0, s2 = 0.0, c1 = 0.0, c2 = 0.0;
    Estimate e;
    for (int i = 0; i < n; ++i) {
        CounterRng rng(seed, static_cast<uint64_t>(i));
        double w = 1.0;
        const auto dir = guide.draw(in, 0, 0, rng, w);
        if (!dir) {
            ++e.died;
            w = 0.0;
        }
        const double c = dir && glm::dot(*dir, axis) > std::cos(coneRad) ? w : 0.0;
        s1 += w;
        s2 += w * w;
        c1 += c;
        c2 += c * c;
    }
    e.weight = s1 / n;
    e.weightError = std::sqrt((s2 / n - e.weight * e.weight) / (n - 1));
    e.cone = c1 / n;
    e.coneError = std::sqrt((c2 / n - e.cone * e.cone) / (n - 1));
    return e;
}

TEST(ScatterGuide, GuidedScattersKeepTheSurfacesIntegrals) {
    int pole = 0, equator = 0, below = 0;
    const ScatterGuide guide = learnedGuide(0.8, pole, equator, below);
    const int n = 200000;
    // Lambertian: the flux within theta of the normal is sin^2 theta of it.
    const OpticalProperty lambert("white", AbsorberSpecular{}, LambertianScatter{0.5, 0.0});
    const Interaction a = scatterAt(lambert);
    const double theta = 0.4;
    const Estimate l = estimate(guide, a, Vec3(0.0, 0.0, 1.0), theta, n, 17);
    EXPECT_LT(std::abs(l.weight - 1.0), 4.0 * l.weightError) << l.weight << " +- " << l.weightError;
    const double inCone = std::sin(theta) * std::sin(theta);
    EXPECT_LT(std::abs(l.cone - inCone), 4.0 * l.coneError) << l.cone << " vs " << inCone;
    // The guide drew a tenth of its directions below the surface: those photons end.
    EXPECT_GT(l.died, 0);
    // No weight beyond 1 / (1 - g) (checked through the mean's spread: a weight of at most 5
    // has variance at most 4 about a mean of 1).
    EXPECT_LT(l.weightError * std::sqrt(n - 1.0), 2.0);
    // A Gaussian lobe of 5 degrees about the specular direction: the flux within 3 degrees of
    // it, against the lobe's own sampling (the same surface, the guide off).
    const OpticalProperty lobe("lobe", AbsorberSpecular{}, GaussianScatter(0.5, 0.0, 5.0));
    const Interaction b = scatterAt(lobe);
    const Vec3 specular = glm::normalize(Vec3(std::sin(0.5236), 0.0, std::cos(0.5236)));
    const double cone = 3.0 * std::numbers::pi / 180.0;
    const Estimate guided = estimate(guide, b, specular, cone, n, 19);
    ScatterGuide off(row());
    off.prepare(std::vector<double>(off.bins(), 0.0), 0.8);
    const Estimate plain = estimate(off, b, specular, cone, n, 23);
    EXPECT_EQ(plain.weightError, 0.0);  // the surface's own sampling: every weight 1
    EXPECT_LT(std::abs(guided.weight - 1.0), 4.0 * guided.weightError);
    EXPECT_LT(std::abs(guided.cone - plain.cone),
              4.0 * std::hypot(guided.coneError, plain.coneError))
        << guided.cone << " vs " << plain.cone;
    EXPECT_GT(plain.cone, 0.2);
}

TEST(ScatterGuide, WeightWindowsKeepTheExpectedFlux) {
    // Slot 0 yields 4x the mean light per scattered flux, slot 1 a hundredth of it, slot 2 has
    // too few scatters learned, slot 3 none.
    ScatterGuide guide(row());
    std::vector<double> learned(guide.bins(), 0.0);
    learned[guide.totalGatheredBin()] = 2.0;
    learned[guide.emittedBin()] = 1.0;  // mean yield 2
    auto set = [&](int slot, double gathered, double scattered, double scatters) {
        learned[guide.gatheredBin(slot)] = gathered;
        learned[guide.scatteredBin(slot)] = scattered;
        learned[guide.scattersBin(slot)] = scatters;
    };
    set(0, 8.0, 1.0, 500.0);
    set(1, 0.02, 1.0, 500.0);
    set(2, 8.0, 1.0, ScatterGuide::kMinScatters - 1.0);
    guide.prepare(learned, 0.0, 2.0);
    EXPECT_DOUBLE_EQ(guide.ratio(0, 0.5), 2.0);
    EXPECT_DOUBLE_EQ(guide.ratio(1, 1.0), 0.01);
    EXPECT_EQ(guide.ratio(2, 1.0), -1.0);
    EXPECT_EQ(guide.ratio(3, 1.0), -1.0);
    EXPECT_FALSE(guide.guides(0));  // a window without the guide
    // photons x factor averages to 1 over the uniform: splits, roulettes, no window.
    auto expected = [&](int slot, double relative, int& split, int& died) {
        const int m = 100000;
        double sum = 0.0;
        split = died = 0;
        for (int i = 0; i < m; ++i) {
            const ScatterGuide::Window w = guide.window(slot, relative, (i + 0.5) / m);
            sum += w.photons * w.factor;
            split = std::max(split, w.photons);
            died += w.photons == 0;
        }
        return sum / m;
    };
    int split = 0, died = 0;
    EXPECT_NEAR(expected(0, 1.5, split, died), 1.0, 1e-12);  // ratio 6: 6 photons
    EXPECT_EQ(split, 6);
    EXPECT_NEAR(expected(0, 10.0, split, died), 1.0, 1e-12);  // ratio 40: kMaxSplit
    EXPECT_EQ(split, ScatterGuide::kMaxSplit);
    EXPECT_NEAR(expected(0, 0.5, split, died), 1.0, 1e-12);  // ratio 2: inside the window
    EXPECT_EQ(split, 1);
    EXPECT_EQ(died, 0);
    EXPECT_NEAR(expected(1, 20.0, split, died), 1.0, 1e-4);  // ratio 0.2: kept 1 in 5
    EXPECT_NEAR(died, 80000, 1);
    EXPECT_NEAR(expected(1, 1.0, split, died), 1.0, 1e-4);  // ratio 0.01: kMinSurvival
    EXPECT_NEAR(died, 100000 * (1.0 - ScatterGuide::kMinSurvival), 1);
    EXPECT_NEAR(expected(2, 1.0, split, died), 1.0, 1e-12);
    EXPECT_EQ(died, 0);
    // Off (0), or an absurd window: refused or no window.
    guide.prepare(learned, 0.0, 0.0);
    EXPECT_EQ(guide.ratio(0, 1.0), -1.0);
    EXPECT_THROW(guide.prepare(learned, 0.0, 0.5), std::invalid_argument);
}

}  // namespace
}  // namespace veil
