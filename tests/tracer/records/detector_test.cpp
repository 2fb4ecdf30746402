// Detectors: the pixel rule at edges and corners, accumulation and reductions against serial
// sums, the variance formula against a direct computation, and z-scores of Monte Carlo
// estimates of known fluxes (with and without ray splitting), and the detector as an emitter
// (pixel rays through an exit aperture: coverage, pdf, etendue). Fixed seeds throughout.

#include "tracer/records/detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <vector>

#include "geometry/scene.h"
#include "lensdata/toml_document.h"
#include "tracer/runtime/rng.h"

namespace veil {
namespace {

// 8 x 4 mm, 8 x 4 pixels of 1 mm: every pixel edge is exactly representable.
DetectorGeometry unitGrid(Frame frame = {}) {
    DetectorGeometry g;
    g.name = "grid";
    g.frame = frame;
    g.widthMm = 8.0;
    g.heightMm = 4.0;
    g.pixelsX = 8;
    g.pixelsY = 4;
    return g;
}

int at(const DetectorImage& im, int column, int row) { return im.pixelIndex(column, row); }

// Pixel Mapping Tests

TEST(DetectorImage, PixelCentresMapToTheirPixels) {
    const DetectorImage im(unitGrid());
    for (int p = 0; p < im.pixelCount(); ++p) {
        const Vec2 c = im.pixelCentreLocal(p);
        EXPECT_EQ(im.pixelOfLocal(c.x, c.y), p) << c;
    }
    // Column 0 is at -x, row 0 at +y.
    EXPECT_EQ(im.pixelOfLocal(-3.5, 1.5), at(im, 0, 0));
    EXPECT_EQ(im.pixelOfLocal(3.5, 1.5), at(im, 7, 0));
    EXPECT_EQ(im.pixelOfLocal(-3.5, -1.5), at(im, 0, 3));
}

TEST(DetectorImage, SharedEdgesGoToTheLargerIndex) {
    const DetectorImage im(unitGrid());
    // x = -1 is the edge between columns 2 and 3.
    EXPECT_EQ(im.pixelOfLocal(-1.0, 1.5), at(im, 3, 0));
    EXPECT_EQ(im.pixelOfLocal(std::nextafter(-1.0, -2.0), 1.5), at(im, 2, 0));
    // y = 1 is the edge between rows 0 (above) and 1 (below).
    EXPECT_EQ(im.pixelOfLocal(0.5, 1.0), at(im, 4, 1));
    EXPECT_EQ(im.pixelOfLocal(0.5, std::nextafter(1.0, 2.0)), at(im, 4, 0));
    // y = 0, x = 0: the centre, a corner of four pixels, goes to the lower right one.
    EXPECT_EQ(im.pixelOfLocal(0.0, 0.0), at(im, 4, 2));
    EXPECT_EQ(im.pixelOfLocal(-1.0, 1.0), at(im, 3, 1));
    // Every interior corner.
    for (int k = 1; k < 8; ++k)
        for (int j = 1; j < 4; ++j)
            EXPECT_EQ(im.pixelOfLocal(-4.0 + k, 2.0 - j), at(im, k, j)) << k << " " << j;
}

TEST(DetectorImage, OuterEdgesAndCornersAreInside) {
    const DetectorImage im(unitGrid());
    EXPECT_EQ(im.pixelOfLocal(-4.0, 2.0), at(im, 0, 0));
    EXPECT_EQ(im.pixelOfLocal(4.0, 2.0), at(im, 7, 0));
    EXPECT_EQ(im.pixelOfLocal(-4.0, -2.0), at(im, 0, 3));
    EXPECT_EQ(im.pixelOfLocal(4.0, -2.0), at(im, 7, 3));
    EXPECT_EQ(im.pixelOfLocal(4.0, 0.3), at(im, 7, 1));
    EXPECT_EQ(im.pixelOfLocal(-0.3, -2.0), at(im, 3, 3));
}

TEST(DetectorImage, OutsidePointsAreRejected) {
    const DetectorImage im(unitGrid());
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    EXPECT_FALSE(im.pixelOfLocal(std::nextafter(4.0, 5.0), 0.0));
    EXPECT_FALSE(im.pixelOfLocal(std::nextafter(-4.0, -5.0), 0.0));
    EXPECT_FALSE(im.pixelOfLocal(0.0, std::nextafter(2.0, 3.0)));
    EXPECT_FALSE(im.pixelOfLocal(0.0, std::nextafter(-2.0, -3.0)));
    EXPECT_FALSE(im.pixelOfLocal(5.0, 3.0));
    EXPECT_FALSE(im.pixelOfLocal(nan, 0.0));
    EXPECT_FALSE(im.pixelOfLocal(0.0, nan));
    EXPECT_FALSE(im.pixelOfLocal(inf, 0.0));
}

TEST(DetectorImage, GlobalPointsUseTheFrameAndProjectAlongItsAxis) {
    // Turned 90 degrees about z and moved to (10, 20, 50): local x = global y - 20,
    // local y = -(global x - 10).
    Frame f;
    f.rotation = glm::dmat3(Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1));
    f.translation = Vec3(10.0, 20.0, 50.0);
    const DetectorImage im(unitGrid(f));
    EXPECT_EQ(im.pixelOf(Vec3(10.0, 23.5, 50.0)), at(im, 7, 2));  // local (3.5, 0)
    EXPECT_EQ(im.pixelOf(Vec3(11.5, 16.5, 50.0)), at(im, 0, 3));  // local (-3.5, -1.5)
    EXPECT_EQ(im.pixelOf(Vec3(11.5, 16.5, 49.2)), at(im, 0, 3));  // off the plane: projected
    EXPECT_FALSE(im.pixelOf(Vec3(10.0, 24.5, 50.0)));             // local x = 4.5
    EXPECT_EQ(im.geometry().normal(), Vec3(0.0, 0.0, -1.0));
}

TEST(DetectorImage, NonBinaryPitchFollowsTheEdgesExactly) {
    // 36 x 24 mm with 720 x 480 pixels (pitch 0.05 mm, not a binary fraction). Oracle: scan
    // the edges for the last one at or before the point. Points are random, on edges and one
    // ulp either side of them.
    DetectorGeometry g;
    g.widthMm = 36.0;
    g.heightMm = 24.0;
    g.pixelsX = 720;
    g.pixelsY = 480;
    const DetectorImage im(g);
    auto oracle = [&](double x, double y) {
        int column = 0, row = 0;
        for (int k = 1; k < 720; ++k)
            if (im.xEdge(k) <= x) column = k;
        for (int j = 1; j < 480; ++j)
            if (y <= im.yEdge(j)) row = j;
        return im.pixelIndex(column, row);
    };
    CounterRng rng(11, 0);
    for (int i = 0; i < 3000; ++i) {
        double x = 36.0 * (rng.uniform() - 0.5), y = 24.0 * (rng.uniform() - 0.5);
        const int k = static_cast<int>(rng.next32() % 721),
                  j = static_cast<int>(rng.next32() % 481);
        switch (i % 4) {
            case 1:
                x = k < 720 ? im.xEdge(k) : 18.0;
                break;
            case 2:
                y = j < 480 ? im.yEdge(j) : -12.0;
                break;
            case 3:
                x = std::nextafter(im.xEdge(std::max(k, 1)), i % 8 == 3 ? -1e9 : 1e9);
                y = std::nextafter(im.yEdge(std::max(j, 1)), i % 8 == 3 ? -1e9 : 1e9);
                break;
        }
        if (std::abs(x) > 18.0 || std::abs(y) > 12.0) continue;
        const std::optional<int> p = im.pixelOfLocal(x, y);
        ASSERT_TRUE(p) << x << " " << y;
        ASSERT_EQ(*p, oracle(x, y)) << x << " " << y;
        const Vec2 c = im.pixelCentreLocal(*p);
        ASSERT_LE(std::abs(x - c.x), 0.025 + 1e-12) << x << " " << y;
        ASSERT_LE(std::abs(y - c.y), 0.025 + 1e-12) << x << " " << y;
    }
}

// Accumulation Tests

TEST(DetectorImage, MergedBlocksEqualSerialAccumulation) {
    // Fluxes are multiples of 2^-10 below 2^10: every partial sum is exact, so any grouping
    // must give the same bits as the serial loop.
    const DetectorImage empty(unitGrid());
    DetectorImage serial = empty;
    std::vector<DetectorImage> blocks(3, empty);
    CounterRng rng(5, 0);
    for (int i = 0; i < 3000; ++i) {
        const int pixel = static_cast<int>(rng.next32() % 32);
        const double flux = (rng.next32() % 1024) / 1024.0;
        serial.add(pixel, flux);
        blocks[i % 3].add(pixel, flux);
    }
    DetectorImage merged = empty;
    for (const DetectorImage& b : blocks) merged.merge(b);
    EXPECT_TRUE(merged.sameSums(serial));
    EXPECT_EQ(merged.totalCount(), 3000u);
    EXPECT_DOUBLE_EQ(merged.totalFlux(), serial.totalFlux());
}

TEST(DetectorImage, FixedBlockMergesAreBitwiseReproducible) {
    // General doubles: the sums depend on the grouping, but one grouping gives the same bits
    // every time, and stays within rounding of the serial sum.
    auto run = [](int blockSize) {
        DetectorImage total(unitGrid());
        for (int start = 0; start < 10000; start += blockSize) {
            DetectorImage block(unitGrid());
            for (int i = start; i < start + blockSize; ++i) {
                CounterRng rng(9, i);
                const int pixel = static_cast<int>(rng.next32() % 32);
                block.add(pixel, rng.uniform() * 1e-3);
            }
            total.merge(block);
        }
        return total;
    };
    const DetectorImage a = run(250), b = run(250), serial = run(10000);
    EXPECT_TRUE(a.sameSums(b));
    for (int p = 0; p < a.pixelCount(); ++p) {
        EXPECT_NEAR(a.flux(p), serial.flux(p), 1e-13 * serial.flux(p));
        EXPECT_EQ(a.count(p), serial.count(p));
    }
}

TEST(DetectorImage, RayContributionCombinesThePixelsOfOneRay) {
    DetectorImage im(unitGrid());
    RayContribution ray;
    ray.add(5, 0.25);
    ray.add(2, 0.5);
    ray.add(5, 0.125);
    im.add(ray);
    EXPECT_TRUE(ray.empty());
    EXPECT_EQ(im.flux(5), 0.375);
    EXPECT_EQ(im.fluxSquared(5), 0.375 * 0.375);  // per ray, not 0.25^2 + 0.125^2
    EXPECT_EQ(im.count(5), 1u);
    EXPECT_EQ(im.flux(2), 0.5);
    EXPECT_EQ(im.totalFlux(), 0.875);
    EXPECT_EQ(im.totalFluxSquared(), 0.875 * 0.875);
    EXPECT_EQ(im.totalCount(), 1u);
    im.add(ray);  // empty: nothing
    EXPECT_EQ(im.totalCount(), 1u);

    RayContribution outside;
    outside.add(32, 1.0);
    EXPECT_THROW(im.add(outside), std::out_of_range);
    EXPECT_THROW(im.add(-1, 1.0), std::out_of_range);

    DetectorGeometry other = unitGrid();
    other.pixelsX = 4;
    EXPECT_THROW(im.merge(DetectorImage(other)), std::invalid_argument);
}

// Statistics Tests

TEST(DetectorImage, VarianceMatchesDirectComputation) {
    // N rays, 60 % of which miss (x = 0); the rest deposit random fluxes in two pixels.
    const uint64_t n = 1000;
    DetectorImage im(unitGrid());
    std::vector<double> x0(n, 0.0), x1(n, 0.0), total(n, 0.0);
    CounterRng rng(3, 0);
    for (uint64_t i = 0; i < n; ++i) {
        if (rng.uniform() < 0.6) continue;
        RayContribution ray;
        const double a = rng.uniform(), b = rng.uniform() * rng.uniform();
        ray.add(0, a);
        x0[i] += a;
        if (rng.uniform() < 0.5) {
            ray.add(1, b);
            x1[i] += b;
        } else {
            ray.add(0, b);
            x0[i] += b;
        }
        total[i] = x0[i] + x1[i];
        im.add(ray);
    }
    // Var(sum) = N * (unbiased sample variance of the x_i).
    auto direct = [&](const std::vector<double>& x) {
        double mean = 0.0;
        for (double v : x) mean += v;
        mean /= n;
        double ss = 0.0;
        for (double v : x) ss += (v - mean) * (v - mean);
        return n * ss / (n - 1);
    };
    EXPECT_NEAR(im.pixelVariance(0, n), direct(x0), 1e-12 * direct(x0));
    EXPECT_NEAR(im.pixelVariance(1, n), direct(x1), 1e-12 * direct(x1));
    EXPECT_NEAR(im.totalVariance(n), direct(total), 1e-12 * direct(total));
    EXPECT_EQ(im.pixelVariance(2, n), 0.0);
    EXPECT_NEAR(im.totalRelativeError(n), std::sqrt(direct(total)) / im.totalFlux(), 1e-12);

    EXPECT_EQ(sumEstimatorVariance(0.0, 0.0, 1), 0.0);
    EXPECT_EQ(sumEstimatorVariance(1.0, 1.0, 1), std::numeric_limits<double>::infinity());
    // Equal samples: zero up to rounding, never negative.
    for (double x : {0.1, 0.3, 1.0 / 3.0, 7e-9}) {
        const double s1 = x + x + x, s2 = x * x + x * x + x * x;
        EXPECT_GE(sumEstimatorVariance(s1, s2, 3), 0.0);
        EXPECT_LE(sumEstimatorVariance(s1, s2, 3), 1e-15 * s2);
    }
    EXPECT_EQ(DetectorImage(unitGrid()).totalRelativeError(100),
              std::numeric_limits<double>::infinity());
}

// A uniform square source of 16 x 16 mm with total flux `phi`, emitting straight onto the
// 8 x 4 mm unit grid at the plane z = 0; every ray carries phi / N times a random factor of
// mean 1 (so the variance is not just binomial). With `split`, each ray arriving on the
// detector is recorded as two children of flux f * a and f * (1 - a) in the same pixel, as a
// ray split at an interface would; `perRay` chooses between RayContribution (correct) and
// one add() per child (sums of squares per hit, wrong).
struct McRun {
    DetectorImage image;
    double expectedTotal;
};
McRun monteCarlo(uint64_t seed, uint64_t n, bool split, bool perRay) {
    const double phi = 2.0;
    McRun run{DetectorImage(unitGrid()), phi * (8.0 * 4.0) / (16.0 * 16.0)};
    RayContribution ray;
    for (uint64_t i = 0; i < n; ++i) {
        CounterRng rng(seed, i);
        const Vec3 p(16.0 * (rng.uniform() - 0.5), 16.0 * (rng.uniform() - 0.5), 0.0);
        const double flux = phi / n * 2.0 * rng.uniform();
        const std::optional<int> pixel = run.image.pixelOf(p);
        if (!pixel) continue;
        if (!split) {
            run.image.add(*pixel, flux);
            continue;
        }
        const double a = rng.uniform();
        if (perRay) {
            ray.add(*pixel, flux * a);
            ray.add(*pixel, flux * (1.0 - a));
            run.image.add(ray);
        } else {
            run.image.add(*pixel, flux * a);
            run.image.add(*pixel, flux * (1.0 - a));
        }
    }
    return run;
}

TEST(DetectorImage, MonteCarloFluxIsWithinItsErrorBars) {
    const uint64_t n = 200000;
    const McRun run = monteCarlo(2024, n, false, true);
    const double z =
        (run.image.totalFlux() - run.expectedTotal) / std::sqrt(run.image.totalVariance(n));
    EXPECT_LT(std::abs(z), 4.0) << "total " << run.image.totalFlux() << " expected "
                                << run.expectedTotal;
    EXPECT_LT(run.image.totalRelativeError(n), 0.01);
    // Every pixel (1 mm^2 of a uniform 256 mm^2 source) expects phi / 256: the sum of the 32
    // squared z-scores is chi-square with 32 degrees of freedom (mean 32, sd 8).
    double chi2 = 0.0;
    for (int p = 0; p < run.image.pixelCount(); ++p) {
        const double zp =
            (run.image.flux(p) - 2.0 / 256.0) / std::sqrt(run.image.pixelVariance(p, n));
        chi2 += zp * zp;
    }
    EXPECT_LT(chi2, 72.0);
    EXPECT_GT(chi2, 8.0);
}

// Mean squared z-score of the total over many independent runs: 1 when the variance
// estimate is right.
double meanSquaredZ(bool split, bool perRay) {
    const int runs = 400;
    const uint64_t n = 1000;
    double sum = 0.0;
    for (int r = 0; r < runs; ++r) {
        const McRun run = monteCarlo(1000 + r, n, split, perRay);
        const double z =
            (run.image.totalFlux() - run.expectedTotal) / std::sqrt(run.image.totalVariance(n));
        sum += z * z;
    }
    return sum / runs;
}

TEST(DetectorImage, ErrorBarsAreCalibratedOverRepeatedRuns) {
    // 400 runs: the mean of z^2 has a standard deviation of about sqrt(2 / 400) = 0.07.
    EXPECT_NEAR(meanSquaredZ(false, true), 1.0, 0.3);
}

TEST(DetectorImage, SplitRaysNeedPerRaySumsOfSquares) {
    // Flushed per ray, split children give calibrated error bars; added per hit they
    // understate the variance about twofold (a^2 + b^2 instead of (a + b)^2).
    EXPECT_NEAR(meanSquaredZ(true, true), 1.0, 0.3);
    EXPECT_GT(meanSquaredZ(true, false), 1.6);
}

// Reading and Placement Tests

ParseError parseErrorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const ParseError& e) {
        return e;
    }
    ADD_FAILURE() << "no ParseError thrown";
    return ParseError({}, "");
}

std::vector<DetectorSpec> read(const std::string& text) {
    TomlDocument doc = TomlDocument::fromString(text, "scene.toml");
    std::vector<DetectorSpec> specs = readDetectors(doc);
    doc.checkAllUsed();
    return specs;
}

TEST(ReadDetectors, OneTableOrAnArrayOfTables) {
    EXPECT_THROW(read("x = 1\n"), ParseError);
    EXPECT_TRUE(read("").empty());

    const auto one =
        read("[detector]\nname = \"sensor\"\nsize_mm = [36.0, 24]\npixels = [720, 480]\n");
    ASSERT_EQ(one.size(), 1u);
    EXPECT_EQ(one[0].name, "sensor");
    EXPECT_EQ(*one[0].sizeMm, Vec2(36.0, 24.0));
    EXPECT_EQ(one[0].pixelsX, 720);
    EXPECT_EQ(one[0].pixelsY, 480);
    EXPECT_FALSE(one[0].zMm);
    EXPECT_TRUE(one[0].object.empty());
    EXPECT_EQ(one[0].loc.line, 1);

    const auto two = read(
        "[[detector]]\nname = \"a\"\nz_mm = 120.5\ncenter_mm = [1, -2]\nsize_mm = [4, 4]\n"
        "[[detector]]\nobject = \"stop\"\npixels = [10, 20]\n");
    ASSERT_EQ(two.size(), 2u);
    EXPECT_EQ(*two[0].zMm, 120.5);
    EXPECT_EQ(two[0].centerMm, Vec2(1.0, -2.0));
    EXPECT_EQ(two[1].object, "stop");
    EXPECT_EQ(two[1].name, "");
    EXPECT_EQ(two[1].objectLoc.line, 7);
    std::ostringstream os;
    os << two[0] << two[1];
    EXPECT_NE(os.str().find("free at z 120.5"), std::string::npos);
}

TEST(ReadDetectors, ErrorsNameTheValueAtFault) {
    auto message = [](const std::string& text) {
        const ParseError e = parseErrorOf([&] { read(text); });
        return e.loc().str() + ": " + e.message();
    };
    EXPECT_NE(message("[detector]\npixels = [0, 10]\n").find("scene.toml:2:"), std::string::npos);
    EXPECT_NE(message("[detector]\npixels = [10.5, 10]\n").find("scene.toml:2:"),
              std::string::npos);
    EXPECT_NE(message("[detector]\npixels = [16384, 16384]\n").find("pixels"), std::string::npos);
    EXPECT_NE(message("[detector]\nsize_mm = [-1, 10]\n").find("scene.toml:2:"), std::string::npos);
    EXPECT_NE(message("[detector]\nsize_mm = [1, 2, 3]\n").find("pair"), std::string::npos);
    EXPECT_NE(message("[detector]\nobject = \"stop\"\nz_mm = 3\n").find("scene.toml:3:"),
              std::string::npos);
    EXPECT_NE(message("[detector]\nz_mm = 3\nsize_mm = [1, 1]\n").find("'name'"),
              std::string::npos);
    EXPECT_NE(message("[detector]\nname = \"d\"\nz_mm = 3\n").find("'size_mm'"), std::string::npos);
    EXPECT_NE(
        message("[[detector]]\nname = \"d\"\n[[detector]]\nname = \"d\"\n").find("scene.toml:4:"),
        std::string::npos);
    EXPECT_NE(message("[detector]\npixel = [10, 10]\n").find("did you mean 'pixels'"),
              std::string::npos);
    EXPECT_NE(message("detector = 3\n").find("[detector]"), std::string::npos);
}

// A scene with the image surface `sensor` (circle of 10 mm radius at z = 50) and a lens face.
Scene smallScene() {
    Scene scene;
    SceneObject lens;
    lens.name = "L1.front";
    lens.kind = ObjectKind::LensFace;
    lens.frame = Frame::alongAxis(10.0);
    lens.geometry = FaceGeometry{SurfacePatch{PlaneShape{}, RectangularAperture{3.0, 2.0}}};
    scene.addObject(lens);
    SceneObject edge;
    edge.name = "L1.edge";
    edge.kind = ObjectKind::LensEdge;
    edge.geometry = FaceGeometry{CylinderPatch{5.0, 0.0, 2.0, true, nullptr}};
    scene.addObject(edge);
    SceneObject sensor;
    sensor.name = "sensor";
    sensor.aliases = {"image"};
    sensor.kind = ObjectKind::Detector;
    sensor.frame = Frame::alongAxis(50.0);
    sensor.geometry = FaceGeometry{SurfacePatch{PlaneShape{}, CircularAperture{10.0}}};
    scene.addObject(sensor);
    return scene;
}

TEST(PlaceDetectors, DefaultsToTheImageSurface) {
    Scene scene = smallScene();
    const std::vector<DetectorGeometry> d = placeDetectors({}, scene);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].name, "sensor");
    EXPECT_EQ(d[0].object, scene.find("sensor")->id);
    EXPECT_EQ(d[0].widthMm, 20.0);
    EXPECT_EQ(d[0].heightMm, 20.0);
    EXPECT_EQ(d[0].pixelsX, 256);
    EXPECT_EQ(d[0].pixelsY, 256);
    EXPECT_EQ(d[0].frame.translation, Vec3(0.0, 0.0, 50.0));
    EXPECT_EQ(d[0].normal(), Vec3(0.0, 0.0, -1.0));

    // On another object, offset, the size from its rectangular aperture.
    DetectorSpec s;
    s.object = "L1.front";
    s.centerMm = Vec2(0.5, 0.0);
    const DetectorGeometry g = placeDetector(s, scene);
    EXPECT_EQ(g.name, "L1.front");
    EXPECT_EQ(g.widthMm, 6.0);
    EXPECT_EQ(g.heightMm, 4.0);
    EXPECT_EQ(g.pixelsX, 256);
    EXPECT_EQ(g.pixelsY, 171);  // near-square pixels
    EXPECT_EQ(g.frame.translation, Vec3(0.5, 0.0, 10.0));
}

TEST(PlaceDetectors, FreeDetectorsJoinTheSceneAndRecordHits) {
    Scene scene = smallScene();
    const auto specs = read(
        "[[detector]]\nname = \"ghost_plane\"\nz_mm = 30\ncenter_mm = [1, 0]\n"
        "size_mm = [8, 4]\npixels = [8, 4]\n[[detector]]\npixels = [64, 64]\n");
    std::vector<DetectorGeometry> d = placeDetectors(specs, scene);
    ASSERT_EQ(d.size(), 2u);
    EXPECT_EQ(d[0].object, -1);
    EXPECT_EQ(d[1].name, "sensor");
    d[0].object = scene.addObject(detectorSceneObject(d[0]));
    scene.commit();

    DetectorImage image(d[0]);
    const Ray ray{Vec3(2.25, 1.5, 20.0), Vec3(0.0, 0.0, 1.0)};
    const std::optional<SceneHit> hit = scene.closestHit(ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->object, d[0].object);
    EXPECT_FALSE(hit->fromFront);  // sensitive side = back of the face
    EXPECT_EQ(image.pixelOf(hit->point), image.pixelIndex(5, 0));  // local (1.25, 1.5)
    // Outside the rectangle: the ray passes on to the sensor.
    const std::optional<SceneHit> miss = scene.closestHit({Vec3(5.5, 0.0, 20.0), Vec3(0, 0, 1)});
    ASSERT_TRUE(miss);
    EXPECT_EQ(scene.object(miss->object).name, "sensor");
}

TEST(PlaceDetectors, ErrorsNameTheObjectOrTheEntry) {
    const Scene scene = smallScene();
    const ParseError unknown =
        parseErrorOf([&] { placeDetectors(read("[detector]\nobject = \"L9.front\"\n"), scene); });
    EXPECT_EQ(unknown.loc().line, 2);
    EXPECT_NE(unknown.message().find("L9.front"), std::string::npos);

    const ParseError clash = parseErrorOf([&] {
        placeDetectors(read("[[detector]]\npixels = [4, 4]\n[[detector]]\nobject = \"image\"\n"),
                       scene);
    });
    EXPECT_NE(clash.message().find("'sensor' is already used"), std::string::npos);

    const ParseError objectName = parseErrorOf([&] {
        placeDetectors(read("[detector]\nname = \"L1.front\"\nz_mm = 3\nsize_mm = [1, 1]\n"),
                       scene);
    });
    EXPECT_EQ(objectName.loc().line, 2);

    DetectorSpec edge;
    edge.object = "L1.edge";
    EXPECT_THROW(placeDetector(edge, scene), ModelError);
    edge.sizeMm = Vec2(2.0, 2.0);
    EXPECT_NO_THROW(placeDetector(edge, scene));

    EXPECT_THROW(placeDetectors({}, Scene()), ModelError);
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// Detector Emission Tests
//
// Pixel rays against independent truths: Pearson's chi-square of where they cross the
// aperture (bins equally probable under uniform area: r^2 and angle), the pdf recomputed here
// from the ray's own intersection with the aperture plane, and the etendue of a small pixel
// through a coaxial disk, A pi sin^2(alpha).

constexpr double kPiD = 3.14159265358979323846;

// A tilted, shifted detector frame and an aperture 40 mm in front of its sensitive side.
Frame tiltedFrame() {
    const Vec3 z = glm::normalize(Vec3(0.1, -0.2, 1.0));
    const Vec3 x = glm::normalize(glm::cross(Vec3(0, 1, 0), z));
    return {glm::dmat3(x, glm::cross(z, x), z), Vec3(3.0, -1.0, 120.0)};
}
ExitAperture apertureBefore(const Frame& f) {
    ExitAperture a;
    a.centerMm = f.toGlobalPoint(Vec3(0.5, -0.3, -40.0));
    a.normal = glm::normalize(f.toGlobalDirection(Vec3(0.15, 0.05, 1.0)));
    a.radiusMm = 6.0;
    return a;
}

// Pearson's chi-square of counts against equal expectations; limit mean + 5 sigma.
struct EqualBins {
    explicit EqualBins(int n) : counts(n, 0) {}
    std::vector<int64_t> counts;
    int64_t total = 0;
    void add(int bin) {
        ++counts.at(bin);
        ++total;
    }
    double statistic() const {
        const double e = static_cast<double>(total) / counts.size();
        double chi = 0.0;
        for (int64_t k : counts) chi += (k - e) * (k - e) / e;
        return chi;
    }
    double limit() const {
        const double dof = counts.size() - 1.0;
        return dof + 5.0 * std::sqrt(2.0 * dof);
    }
};

TEST(DetectorEmission, RaysLeaveThePixelUniformlyAndCoverTheApertureUniformly) {
    const Frame f = tiltedFrame();
    const DetectorImage im(unitGrid(f));
    const ExitAperture a = apertureBefore(f);
    const int pixel = im.pixelIndex(2, 1);
    // The test's own basis on the aperture (any: uniform area is uniform in angle).
    const Vec3 e1 = glm::normalize(glm::cross(a.normal, Vec3(0.3, 1.0, 0.2)));
    const Vec3 e2 = glm::cross(a.normal, e1);
    EqualBins aperture(10 * 8), footprint(16);
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        CounterRng rng(404, static_cast<uint64_t>(i));
        const PixelRay r = samplePixelRay(im, pixel, a, rng);
        ASSERT_EQ(im.pixelOf(r.ray.origin), pixel) << r;
        const Vec3 q = r.aperturePointMm - a.centerMm;
        ASSERT_NEAR(glm::dot(q, a.normal), 0.0, 1e-12);
        ASSERT_NEAR(glm::length(r.ray.origin + r.distanceMm * r.ray.direction - r.aperturePointMm),
                    0.0, 1e-11);
        const double s = glm::dot(q, q) / (a.radiusMm * a.radiusMm);
        ASSERT_LE(s, 1.0);
        double phi = std::atan2(glm::dot(q, e2), glm::dot(q, e1));
        if (phi < 0.0) phi += 2.0 * kPiD;
        aperture.add(std::min(9, static_cast<int>(s * 10)) * 8 +
                     std::min(7, static_cast<int>(phi / (2.0 * kPiD) * 8)));
        const Vec3 local = f.toLocalPoint(r.ray.origin);
        const int ix = std::min(3, static_cast<int>((local.x - im.xEdge(2)) * 4));
        const int iy = std::min(3, static_cast<int>((im.yEdge(1) - local.y) * 4));
        footprint.add(ix * 4 + iy);
        ASSERT_EQ(r.importance, 1.0);  // the aperture is in front of the sensitive side
    }
    EXPECT_LT(aperture.statistic(), aperture.limit()) << "aperture, 80 bins";
    EXPECT_LT(footprint.statistic(), footprint.limit()) << "pixel, 16 bins";
}

// A grid over a round sensor (the default detector: the box of the sensor's disc) records
// only where the sensor is, as a forward ray records only what hits the object: a pixel ray
// from a corner outside the disc carries no importance. The fraction of the grid's pixel
// rays that do is the disc's share of the square, pi / 4, within 5 binomial sigmas.
TEST(DetectorEmission, OnlyTheObjectsApertureIsSensitive) {
    DetectorGeometry g = unitGrid(tiltedFrame());
    g.widthMm = g.heightMm = 4.0;
    g.pixelsX = g.pixelsY = 4;
    g.aperture = CircularAperture{2.0};
    const DetectorImage im(g);
    const ExitAperture a = apertureBefore(g.frame);
    int sensitive = 0;
    const int n = 40000;
    for (int i = 0; i < n; ++i) {
        CounterRng rng(406, static_cast<uint64_t>(i));
        const int pixel = i % im.pixelCount();
        const PixelRay r = samplePixelRay(im, pixel, a, rng);
        const Vec3 local = g.frame.toLocalPoint(r.ray.origin);
        const bool inside = std::hypot(local.x, local.y) <= 2.0;
        ASSERT_EQ(r.importance, inside ? 1.0 : 0.0) << r;
        ASSERT_EQ(pixelImportance(im, pixel, r.ray), inside ? 1.0 : 0.0) << r;
        EXPECT_GT(r.pdf, 0.0);  // the sampling itself is unchanged
        sensitive += inside;
    }
    const double p = kPiD / 4.0, sigma = std::sqrt(p * (1.0 - p) / n);
    EXPECT_NEAR(static_cast<double>(sensitive) / n, p, 5.0 * sigma);
    // The corner pixel (0, 0) lies wholly outside the disc except its inner corner.
    EXPECT_FALSE(g.sensitiveAt(-1.9, 1.9));
    EXPECT_TRUE(g.sensitiveAt(-1.0, 1.0));
    // Placed on an object, the detector takes its aperture, shifted by its centre.
    Scene scene;
    SceneObject o;
    o.name = "sensor";
    o.kind = ObjectKind::Detector;
    o.geometry = FaceGeometry{SurfacePatch{SurfaceShape{}, CircularAperture{5.0}}};
    scene.addObject(o);
    DetectorSpec spec;
    spec.centerMm = Vec2(3.0, 0.0);
    spec.sizeMm = Vec2(4.0, 4.0);
    const DetectorGeometry placed = placeDetector(spec, scene);
    ASSERT_TRUE(placed.aperture);
    EXPECT_TRUE(placed.sensitiveAt(1.9, 0.0));   // x = 4.9 on the object
    EXPECT_FALSE(placed.sensitiveAt(1.9, 1.9));  // r = 5.25 on the object
}

TEST(DetectorEmission, PdfIsTheAreaProductTimesTheSolidAngleJacobian) {
    const Frame f = tiltedFrame();
    const DetectorImage im(unitGrid(f));
    const ExitAperture a = apertureBefore(f);
    for (int i = 0; i < 2000; ++i) {
        CounterRng rng(405, static_cast<uint64_t>(i));
        const int pixel = i % im.pixelCount();
        const PixelRay r = samplePixelRay(im, pixel, a, rng);
        // Independently: where the ray meets the aperture plane, and the formula
        // pdf = 1 / A_pixel * 1 / (pi R^2) * t^2 / cos.
        const double cosA = std::abs(glm::dot(r.ray.direction, a.normal));
        const double t =
            glm::dot(a.centerMm - r.ray.origin, a.normal) / glm::dot(r.ray.direction, a.normal);
        const double expected = t * t / (1.0 * kPiD * 36.0 * cosA);  // 1 mm^2 pixels
        ASSERT_NEAR(r.pdf, expected, 1e-12 * expected) << r;
        ASSERT_NEAR(pixelRayPdf(im, pixel, a, r.ray), expected, 1e-12 * expected) << r;
        EXPECT_EQ(pixelImportance(im, pixel, r.ray), 1.0);
        // Another pixel, or a ray that misses the disk, was not sampled.
        EXPECT_EQ(pixelRayPdf(im, (pixel + 1) % im.pixelCount(), a, r.ray), 0.0);
        EXPECT_EQ(pixelImportance(im, (pixel + 1) % im.pixelCount(), r.ray), 0.0);
        const Ray wide{
            r.ray.origin,
            glm::normalize(a.centerMm + 6.5 * glm::normalize(glm::cross(a.normal, Vec3(1, 0, 0))) -
                           r.ray.origin)};
        EXPECT_EQ(pixelRayPdf(im, pixel, a, wide), 0.0);
        // Leaving through the back of the detector carries no importance.
        EXPECT_EQ(pixelImportance(im, pixel, {r.ray.origin, -r.ray.direction}), 0.0);
    }
}

TEST(DetectorEmission, EtendueOfASmallPixelThroughACoaxialDisk) {
    // A 10 um pixel on the axis of a disk of radius 10 mm, 50 mm in front of its sensitive
    // side: G = A pi sin^2(alpha), sin^2(alpha) = R^2 / (R^2 + D^2); the finite pixel changes
    // it by ~(10 um / 50 mm)^2.
    DetectorGeometry g;
    g.name = "pixel";
    g.frame = tiltedFrame();
    g.widthMm = g.heightMm = 0.01;
    g.pixelsX = g.pixelsY = 1;
    const DetectorImage im(g);
    ExitAperture a;
    a.centerMm = g.frame.toGlobalPoint(Vec3(0.0, 0.0, -50.0));
    a.normal = g.frame.toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    a.radiusMm = 10.0;
    const double sin2 = 100.0 / (100.0 + 2500.0);
    const double etendue = 1e-4 * kPiD * sin2;
    const int n = 100000;
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < n; ++i) {
        CounterRng rng(406, static_cast<uint64_t>(i));
        const PixelRay r = samplePixelRay(im, 0, a, rng);
        const double x = r.importance * r.cosPixel / r.pdf;
        s1 += x;
        s2 += x * x;
    }
    const double mean = s1 / n;
    const double sigma = std::sqrt((s2 / n - mean * mean) / (n - 1));
    EXPECT_LT(std::abs(mean - etendue) / sigma, 4.0)
        << mean << " +- " << sigma << " vs " << etendue;
    EXPECT_LT(sigma, 0.01 * etendue);
}

TEST(DetectorEmission, PixelCornersBoundThePixel) {
    const Frame f = tiltedFrame();
    const DetectorImage im(unitGrid(f));
    for (int p = 0; p < im.pixelCount(); ++p) {
        const std::array<Vec3, 4> c = pixelCornersGlobal(im, p);
        // The centre of the four is the pixel centre, and the sides are the pitch.
        EXPECT_EQ(im.pixelOf(0.25 * (c[0] + c[1] + c[2] + c[3])), p);
        const Vec2 centre = im.pixelCentreLocal(p);
        EXPECT_NEAR(
            glm::length(0.25 * (c[0] + c[1] + c[2] + c[3]) - f.toGlobalPoint(Vec3(centre, 0.0))),
            0.0, 1e-12);
        EXPECT_NEAR(glm::length(c[1] - c[0]), im.geometry().pixelWidthMm(), 1e-12);
        EXPECT_NEAR(glm::length(c[3] - c[0]), im.geometry().pixelHeightMm(), 1e-12);
        EXPECT_NEAR(glm::dot(glm::cross(c[1] - c[0], c[3] - c[0]), im.geometry().normal()),
                    im.geometry().pixelAreaMm2(), 1e-12);  // top-left, top-right, bottom-left
    }
    // Without rotation the corners are exact: the top-left one belongs to the pixel by the
    // boundary rule, the others to its right, lower and lower-right neighbours (or nobody
    // past the outer edges, which are inside).
    const DetectorImage flat(unitGrid());
    const std::array<Vec3, 4> c = pixelCornersGlobal(flat, at(flat, 3, 1));
    EXPECT_EQ(flat.pixelOf(c[0]), at(flat, 3, 1));
    EXPECT_EQ(flat.pixelOf(c[1]), at(flat, 4, 1));
    EXPECT_EQ(flat.pixelOf(c[2]), at(flat, 4, 2));
    EXPECT_EQ(flat.pixelOf(c[3]), at(flat, 3, 2));
    std::ostringstream os;
    os << apertureBefore(f);
    CounterRng rng(1, 1);
    os << samplePixelRay(im, 0, apertureBefore(f), rng);
    EXPECT_NE(os.str().find("ExitAperture{"), std::string::npos);
    EXPECT_NE(os.str().find("PixelRay{pixel 0"), std::string::npos);
}

}  // namespace
}  // namespace veil
