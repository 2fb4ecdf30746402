// Apertures against their definitions in polar or box form, with edge points exactly on the
// boundary counted as inside.

#include "geometry/aperture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

namespace veil {
namespace {

TEST(Aperture, CircularEdgeIsInside) {
    const Aperture a = CircularAperture{5.0};
    EXPECT_TRUE(apertureContains(a, 0.0, 0.0));
    EXPECT_TRUE(apertureContains(a, 5.0, 0.0));
    EXPECT_TRUE(apertureContains(a, 0.0, -5.0));
    EXPECT_TRUE(apertureContains(a, 3.0, 4.0));  // r = 5 exactly
    EXPECT_TRUE(apertureContains(a, -3.0, -4.0));
    EXPECT_FALSE(apertureContains(a, std::nextafter(5.0, 6.0), 0.0));
    EXPECT_FALSE(apertureContains(a, 3.0, 4.000001));
    // Edges at radii that are not representable squares stay inside too.
    const Aperture b = CircularAperture{0.1};
    EXPECT_TRUE(apertureContains(b, 0.1, 0.0));
    EXPECT_TRUE(apertureContains(b, 0.0, -0.1));
    EXPECT_FALSE(apertureContains(b, std::nextafter(0.1, 1.0), 0.0));
}

TEST(Aperture, AnnularBothEdgesAreInside) {
    const Aperture a = AnnularAperture{2.0, 10.0};
    EXPECT_FALSE(apertureContains(a, 0.0, 0.0));  // central obscuration
    EXPECT_FALSE(apertureContains(a, 1.0, 1.0));
    EXPECT_TRUE(apertureContains(a, 2.0, 0.0));    // inner edge
    EXPECT_TRUE(apertureContains(a, 0.0, -10.0));  // outer edge
    EXPECT_TRUE(apertureContains(a, 6.0, 8.0));
    EXPECT_TRUE(apertureContains(a, 5.0, 5.0));
    EXPECT_FALSE(apertureContains(a, std::nextafter(2.0, 0.0), 0.0));
    EXPECT_FALSE(apertureContains(a, 0.0, std::nextafter(10.0, 11.0)));
    // Without obscuration it is a disc.
    EXPECT_TRUE(apertureContains(AnnularAperture{0.0, 1.0}, 0.0, 0.0));
}

TEST(Aperture, RectangularEdgesAndCornersAreInside) {
    const Aperture a = RectangularAperture{3.0, 2.0};
    EXPECT_TRUE(apertureContains(a, 3.0, 2.0));
    EXPECT_TRUE(apertureContains(a, -3.0, -2.0));
    EXPECT_TRUE(apertureContains(a, -3.0, 0.5));
    EXPECT_TRUE(apertureContains(a, 0.0, 2.0));
    EXPECT_FALSE(apertureContains(a, std::nextafter(3.0, 4.0), 0.0));
    EXPECT_FALSE(apertureContains(a, 0.0, std::nextafter(-2.0, -3.0)));
    EXPECT_FALSE(apertureContains(a, 2.5, 2.5));  // inside the bounding circle, outside the box
}

TEST(Aperture, RandomPointsMatchPolarAndBoxDefinitions) {
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> uni(-12.0, 12.0);
    const Aperture circle = CircularAperture{7.5};
    const Aperture ring = AnnularAperture{2.5, 9.0};
    const Aperture box = RectangularAperture{8.0, 4.5};
    int inCircle = 0, inRing = 0, inBox = 0;
    for (int i = 0; i < 20000; ++i) {
        const double x = uni(rng), y = uni(rng);
        const long double r = std::hypot(static_cast<long double>(x), static_cast<long double>(y));
        // Points within 1e-12 of an edge are left out: there the rounding of the squares and
        // of hypot may legitimately differ.
        auto clear = [r](long double edge) { return std::abs(r - edge) > 1e-12L; };
        if (clear(7.5L)) {
            ASSERT_EQ(apertureContains(circle, x, y), r < 7.5L) << x << ", " << y;
            inCircle += r < 7.5L;
        }
        if (clear(2.5L) && clear(9.0L)) {
            ASSERT_EQ(apertureContains(ring, x, y), r > 2.5L && r < 9.0L) << x << ", " << y;
            inRing += r > 2.5L && r < 9.0L;
        }
        ASSERT_EQ(apertureContains(box, x, y), std::abs(x) <= 8.0 && std::abs(y) <= 4.5);
        inBox += std::abs(x) <= 8.0 && std::abs(y) <= 4.5;
    }
    // The hit fractions agree with the areas (576 mm^2 sampled), a 5-sigma binomial check.
    auto expectFraction = [](int count, double area) {
        const double p = area / 576.0;
        EXPECT_NEAR(count / 20000.0, p, 5.0 * std::sqrt(p * (1.0 - p) / 20000.0));
    };
    expectFraction(inCircle, M_PI * 7.5 * 7.5);
    expectFraction(inRing, M_PI * (81.0 - 6.25));
    expectFraction(inBox, 16.0 * 9.0);
}

TEST(Aperture, BoundingRadiusHoldsTheAperture) {
    EXPECT_EQ(apertureBoundingRadius(CircularAperture{4.0}), 4.0);
    EXPECT_EQ(apertureBoundingRadius(AnnularAperture{1.0, 6.0}), 6.0);
    // The rectangle's corner radius, rounded up by at most an ulp so corners lie within it.
    const double r = apertureBoundingRadius(RectangularAperture{3.0, 4.0});
    EXPECT_GE(r, 5.0);
    EXPECT_LE(r, std::nextafter(5.0, 6.0));
    const RectangularAperture odd{0.1, 0.7};
    const double ro = apertureBoundingRadius(odd);
    EXPECT_GE(ro, std::sqrt(0.1 * 0.1 + 0.7 * 0.7));
    EXPECT_NEAR(ro, std::sqrt(0.5), 1e-15);
    // Every corner of random rectangles is inside.
    std::mt19937_64 rng(22);
    std::uniform_real_distribution<double> uni(0.001, 100.0);
    for (int i = 0; i < 1000; ++i) {
        const double w = uni(rng), h = uni(rng);
        const double rb = apertureBoundingRadius(RectangularAperture{w, h});
        ASSERT_LE(std::sqrt(w * w + h * h), rb);
        ASSERT_TRUE(apertureContains(CircularAperture{rb}, w, h));
    }
}

TEST(Aperture, PrintsItself) {
    std::ostringstream os;
    os << Aperture{CircularAperture{5}} << "; " << Aperture{AnnularAperture{1, 2}} << "; "
       << Aperture{RectangularAperture{3, 4}};
    EXPECT_EQ(os.str(),
              "CircularAperture{radius 5 mm}; AnnularAperture{inner 1 mm, outer 2 mm}; "
              "RectangularAperture{half width 3 mm, half height 4 mm}");
}

}  // namespace
}  // namespace veil
