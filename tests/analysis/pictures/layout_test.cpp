// Layouts: the legend lists exactly the kinds of part drawn, the detector carries its object
// name, and sources are drawn where they are: beam arrows parallel to the beam and ending
// where a brute-force closest hit says the ray first meets the scene, point-source rays
// spread over the cone the source emits into, area sources as the section of their area.

#include "analysis/pictures/layout.h"

#include <cairo.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <regex>
#include <set>

#include "analysis/pictures/scene_section.h"
#include "geometry/scene.h"
#include "tests/analysis/prepared_scene.h"

namespace veil {
namespace {

using test::prepare;
using test::Prepared;

const std::string kSunScene = VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml";
const std::string kWindowScene = VEIL_SOURCE_DIR "/examples/scenes/catadioptric_2000mm_window.toml";

std::filesystem::path scratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::filesystem::path dir = std::filesystem::path(VEIL_BINARY_DIR) / "test_scratch" /
                                      "layout" /
                                      (std::string(info->test_suite_name()) + "." + info->name());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

// The long-focus lens alone (no mechanics) lit by a point, a Lambertian panel and a beam.
std::filesystem::path threeSourceScene() {
    return test::writeScene("layout_three_sources", R"(
lens = ")" VEIL_SOURCE_DIR R"(/examples/lenses/longfocus_360mm.toml"

[[source]]
name = "lamp"
kind = "point"
position_mm = [0.0, 20.0, -300.0]

[[source]]
name = "panel"
kind = "lambertian"
position_mm = [0.0, 0.0, -50.0]
size_mm = [20.0, 10.0]

[[source]]
name = "beam"
kind = "collimated"
field_deg = 5.0
)");
}

std::vector<std::string> legendLabels(const Picture& pic) {
    std::vector<std::string> out;
    for (const LegendEntry& e : pic.legendEntries()) out.push_back(e.label);
    return out;
}

Vec2 unit(const Vec2& v) { return v / glm::length(v); }

// Layout Sources Tests

TEST(LayoutSources, BeamArrowsAreParallelAndEndWhereTheRayFirstMeetsTheScene) {
    const Prepared r = prepare(kSunScene);
    const Scene& scene = r.setup->scene;
    LayoutSourceOptions o;
    o.minBeamArrowMm = 30.0;
    const std::vector<LayoutSource> s = layoutSources(r.trace.view.sources, scene, o);
    ASSERT_EQ(s.size(), 1u);
    EXPECT_EQ(s[0].name, "sun");
    EXPECT_EQ(s[0].kind, "sun");
    EXPECT_TRUE(s[0].emitterZY.empty());
    ASSERT_EQ(s[0].arrows.size(), 7u);
    const Beam& beam = std::get<SunSource>(r.trace.view.sources[0].shape()).beam;
    // The sun 7 deg off axis in y: the beam runs along (z, y) = (cos 7, sin 7).
    const Vec2 along(beam.direction.z, beam.direction.y);
    EXPECT_NEAR(along.y / along.x, std::tan(7.0 * M_PI / 180.0), 1e-12);
    double shortest = kInfinity;
    for (const LayoutSource::Arrow& a : s[0].arrows) {
        const Vec2 d = a.toZY - a.fromZY;
        EXPECT_NEAR(unit(d).x, unit(along).x, 1e-9) << s[0];
        EXPECT_NEAR(unit(d).y, unit(along).y, 1e-9) << s[0];
        shortest = std::min(shortest, glm::length(d));
        // Oracle: the same ray from its start disk, brute force. The beam lies in the x = 0
        // plane (no x field), so the section shows it unprojected.
        const double setBack =
            glm::dot(Vec2(beam.startCenterMm.z, beam.startCenterMm.y) - a.fromZY, unit(along));
        const Vec2 start = a.fromZY + setBack * unit(along);
        const Vec3 origin(0.0, start.y, start.x);
        const std::optional<SceneHit> hit = scene.closestHitBruteForce(Ray{origin, beam.direction});
        ASSERT_TRUE(hit) << s[0];
        EXPECT_NEAR(a.toZY.x, hit->point.z, 1e-6);
        EXPECT_NEAR(a.toZY.y, hit->point.y, 1e-6);
    }
    EXPECT_NEAR(shortest, 30.0, 1e-6);
    EXPECT_EQ(s[0].detail, "7 deg off axis");
    // The arrows span the start disk.
    const double across = glm::length(s[0].arrows.front().fromZY - s[0].arrows.back().fromZY);
    EXPECT_NEAR(across, 2.0 * beam.radiusMm, 1e-6);
}

TEST(LayoutSources, PointAndAreaSourcesAreDrawnWhereTheyEmit) {
    const Prepared r = prepare(threeSourceScene());
    const std::vector<Source>& sources = r.trace.view.sources;
    const std::vector<LayoutSource> s = layoutSources(sources, r.setup->scene);
    ASSERT_EQ(s.size(), 3u);

    // Point: a dot at (z, y) = (-300, 20), rays from it spread over its cone, the outer rays
    // at 90 % of the cone's half-angle from its axis.
    EXPECT_EQ(s[0].kind, "point");
    {
        // The label gives the cone's half-angle to 3 digits.
        const PointSource& lamp = std::get<PointSource>(sources[0].shape());
        std::smatch m;
        ASSERT_TRUE(std::regex_match(s[0].detail, m, std::regex(R"(\+-([0-9.]+) deg cone)")))
            << s[0].detail;
        EXPECT_NEAR(std::stod(m[1]), lamp.halfAngleRad * 180.0 / M_PI,
                    5e-3 * lamp.halfAngleRad * 180.0 / M_PI);
    }
    ASSERT_EQ(s[0].emitterZY.size(), 1u);
    EXPECT_EQ(s[0].emitterZY[0], Vec2(-300.0, 20.0));
    ASSERT_EQ(s[0].arrows.size(), 5u);
    const PointSource& p = std::get<PointSource>(sources[0].shape());
    const Vec2 axis = unit(Vec2(p.axis.z, p.axis.y));
    for (size_t i = 0; i < s[0].arrows.size(); ++i) {
        const LayoutSource::Arrow& a = s[0].arrows[i];
        EXPECT_EQ(a.fromZY, Vec2(-300.0, 20.0));
        const double angle =
            std::acos(std::clamp(glm::dot(unit(a.toZY - a.fromZY), axis), -1.0, 1.0));
        const double want = std::abs(0.9 * p.halfAngleRad * (2.0 * i / 4.0 - 1.0));
        EXPECT_NEAR(angle, want, 1e-9) << i;
        // Every ray drawn ends on the lens's first surface, near z = 0 (oracle: brute force).
        const Vec3 dir = glm::normalize(Vec3(0.0, a.toZY.y - 20.0, a.toZY.x + 300.0));
        const std::optional<SceneHit> hit =
            r.setup->scene.closestHitBruteForce(Ray{Vec3(0.0, 20.0, -300.0), dir});
        ASSERT_TRUE(hit) << i;
        EXPECT_NEAR(hit->point.z, a.toZY.x, 1e-6) << i;
        EXPECT_EQ(r.setup->scene.object(hit->object).name, "L1.front") << i;
    }

    // Lambertian 20 x 10 mm panel at z = -50 facing +z: its section runs along y, 10 mm
    // long; rays from its ends and centre along the normal, from its centre at +-45 deg.
    EXPECT_EQ(s[1].kind, "lambertian");
    ASSERT_EQ(s[1].emitterZY.size(), 2u);
    EXPECT_NEAR(s[1].emitterZY[0].x, -50.0, 1e-12);
    EXPECT_NEAR(s[1].emitterZY[1].x, -50.0, 1e-12);
    EXPECT_NEAR(std::abs(s[1].emitterZY[0].y - s[1].emitterZY[1].y), 10.0, 1e-12);
    ASSERT_EQ(s[1].arrows.size(), 5u);
    std::multiset<long> angles;
    for (const LayoutSource::Arrow& a : s[1].arrows) {
        const Vec2 d = unit(a.toZY - a.fromZY);
        angles.insert(std::lround(std::atan2(d.y, d.x) * 180.0 / M_PI));
        EXPECT_NEAR(a.fromZY.x, -50.0, 1e-12);
    }
    EXPECT_EQ(angles, (std::multiset<long>{-45, 0, 0, 0, 45}));
    EXPECT_EQ(s[1].detail, "");  // a whole hemisphere: the kind says it

    // The beam: 7 parallel arrows at 5 deg.
    EXPECT_EQ(s[2].kind, "collimated");
    ASSERT_EQ(s[2].arrows.size(), 7u);
    for (const LayoutSource::Arrow& a : s[2].arrows) {
        const Vec2 d = unit(a.toZY - a.fromZY);
        EXPECT_NEAR(d.y / d.x, std::tan(5.0 * M_PI / 180.0), 1e-9);
    }
    EXPECT_EQ(s[2].detail, "5 deg off axis");
    EXPECT_THROW(layoutSources(sources, r.setup->scene, {0, 5, 0.0}), std::invalid_argument);
}

TEST(LayoutSources, TheWindowIsADiskInFrontOfTheLens) {
    const Prepared r = prepare(kWindowScene);
    const std::vector<LayoutSource> s = layoutSources(r.trace.view.sources, r.setup->scene);
    ASSERT_EQ(s.size(), 1u);
    EXPECT_EQ(s[0].kind, "window");
    const WindowSource& w = std::get<WindowSource>(r.trace.view.sources[0].shape());
    ASSERT_EQ(s[0].emitterZY.size(), 2u);
    EXPECT_NEAR(std::abs(s[0].emitterZY[0].y - s[0].emitterZY[1].y), 2.0 * w.area.radiusMm, 1e-9);
    // 0.1 mm in front of the lens's front-most point (docs/format.md).
    const double front = entranceAperture(r.file.prescription, *r.file.model).frontZMm;
    EXPECT_NEAR(s[0].emitterZY[0].x, front - 0.1, 1e-9);
    EXPECT_NEAR(s[0].emitterZY[1].x, front - 0.1, 1e-9);
    for (const LayoutSource::Arrow& a : s[0].arrows) EXPECT_GT(a.toZY.x, a.fromZY.x);
    EXPECT_EQ(s[0].detail, "+-3.25 deg cone");  // the scene's cone_deg
}

// Layout Drawing Tests

TEST(DrawLayout, TheLegendListsTheKindsDrawn) {
    const Prepared sun = prepare(kSunScene);
    const Picture withMechanics = drawLayout(sun.setup->scene, {});
    EXPECT_EQ(legendLabels(withMechanics),
              (std::vector<std::string>{"glass", "mechanics", "aperture stop", "detector",
                                        "optical axis"}));

    // Oracle: the kinds in the section itself.
    const Prepared bare = prepare(threeSourceScene());
    std::set<ObjectKind> kinds;
    for (const SectionPath& p : sceneSection(bare.setup->scene, 0.005)) kinds.insert(p.kind);
    EXPECT_EQ(kinds.count(ObjectKind::Mechanics), 0u);
    LayoutOptions o;
    o.sources = layoutSources(bare.trace.view.sources, bare.setup->scene);
    const std::vector<std::string> labels = legendLabels(drawLayout(bare.setup->scene, o));
    auto has = [&](const char* l) {
        return std::find(labels.begin(), labels.end(), l) != labels.end();
    };
    EXPECT_FALSE(has("mechanics"));
    EXPECT_EQ(has("glass"), kinds.count(ObjectKind::LensFace) + kinds.count(ObjectKind::LensEdge) +
                                    kinds.count(ObjectKind::LensFlat) >
                                0);
    EXPECT_TRUE(has("glass"));
    EXPECT_EQ(has("aperture stop"), kinds.count(ObjectKind::Stop) > 0);
    EXPECT_EQ(has("detector"), kinds.count(ObjectKind::Detector) > 0);
    EXPECT_TRUE(has("source"));
    EXPECT_EQ(labels.back(), "source");
}

// A detector's grid cut by the section plane x = 0: the segment across its recorded area, in
// any orientation, and nothing for a grid the plane misses.
TEST(LayoutDetectors, TheGridIsCutByTheSectionPlane) {
    DetectorGeometry g;
    g.name = "grid";
    g.widthMm = 64.0;
    g.heightMm = 48.0;
    g.frame = Frame::alongAxis(100.0);
    std::vector<LayoutDetector> d = layoutDetectors({g});
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].name, "grid");
    EXPECT_NEAR(d[0].fromZY.x, 100.0, 1e-12);
    EXPECT_NEAR(d[0].toZY.x, 100.0, 1e-12);
    EXPECT_NEAR(std::abs(d[0].fromZY.y - d[0].toZY.y), 48.0, 1e-12);  // the height lies along y
    EXPECT_NEAR(d[0].fromZY.y + d[0].toZY.y, 0.0, 1e-12);
    // Turned 90 degrees about z: its width along y.
    DetectorGeometry turned = g;
    turned.frame.rotation = glm::dmat3(Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1));
    d = layoutDetectors({turned});
    ASSERT_EQ(d.size(), 1u);
    EXPECT_NEAR(std::abs(d[0].fromZY.y - d[0].toZY.y), 64.0, 1e-9);
    // Tilted 30 degrees about x: the section is the tilted height, its ends off the plane z.
    DetectorGeometry tilted = g;
    const double c = std::cos(kPi / 6.0), sn = std::sin(kPi / 6.0);
    tilted.frame.rotation = glm::dmat3(Vec3(1, 0, 0), Vec3(0, c, sn), Vec3(0, -sn, c));
    d = layoutDetectors({tilted});
    ASSERT_EQ(d.size(), 1u);
    EXPECT_NEAR(glm::length(d[0].fromZY - d[0].toZY), 48.0, 1e-9);
    EXPECT_NEAR(std::abs(d[0].fromZY.x - d[0].toZY.x), 48.0 * sn, 1e-9);
    // Moved off to x = 40 mm: the plane misses it.
    DetectorGeometry aside = g;
    aside.frame.translation = Vec3(40.0, 0.0, 100.0);
    EXPECT_TRUE(layoutDetectors({aside}).empty());
}

// With the grids given, the layout draws the recorded area and names it in the legend, the
// sensor surface under it.
TEST(DrawLayout, TheDetectorIsDrawnAsItsGrid) {
    const Prepared sun = prepare(kSunScene);
    LayoutOptions o;
    o.detectors = layoutDetectors(sun.setup->detectors);
    ASSERT_EQ(o.detectors.size(), 1u);
    // The sun scene's 64 mm detector on its larger sensor surface.
    EXPECT_NEAR(std::abs(o.detectors[0].fromZY.y - o.detectors[0].toZY.y), 64.0, 1e-9);
    EXPECT_EQ(legendLabels(drawLayout(sun.setup->scene, o)),
              (std::vector<std::string>{"glass", "mechanics", "aperture stop", "sensor surface",
                                        "detector (recorded area)", "optical axis"}));
}

TEST(DrawLayout, LegendSwatchesLookLikeWhatIsDrawn) {
    // The catadioptric lens's mirrors are open curves, its elements and mechanics closed.
    const Prepared r = prepare(kWindowScene);
    std::map<std::string, LegendEntry::Swatch> swatch;
    const Picture pic = drawLayout(r.setup->scene, {});
    for (const LegendEntry& e : pic.legendEntries()) swatch[e.label] = e.swatch;
    EXPECT_EQ(swatch.at("mirror"), LegendEntry::Swatch::Line);
    EXPECT_EQ(swatch.at("detector"), LegendEntry::Swatch::Line);
    EXPECT_EQ(swatch.at("glass"), LegendEntry::Swatch::Fill);
    EXPECT_EQ(swatch.at("mechanics"), LegendEntry::Swatch::Fill);
    EXPECT_EQ(swatch.at("optical axis"), LegendEntry::Swatch::DashedLine);
    EXPECT_EQ(swatch.count("source"), 0u);
}

TEST(DrawLayout, SourcesAndTheDetectorNameAppearInTheSvg) {
    const Prepared r = prepare(kSunScene);
    LayoutOptions o;
    o.title = "Long focus & <sun>";
    const std::string without = drawLayout(r.setup->scene, o).svg();
    o.sources = layoutSources(r.trace.view.sources, r.setup->scene);
    const Picture pic = drawLayout(r.setup->scene, o);
    const std::string svg = pic.svg();
    const std::regex sourceLabel("<text [^>]*>sun, 7 deg off axis</text>");
    EXPECT_TRUE(std::regex_search(svg, sourceLabel));
    EXPECT_FALSE(std::regex_search(without, sourceLabel));
    // Arrows in the source colour: one filled head per arrow.
    const std::regex head("<polygon [^>]*fill=\"#e8710a\"");
    const auto heads =
        std::distance(std::sregex_iterator(svg.begin(), svg.end(), head), std::sregex_iterator());
    EXPECT_EQ(heads, 7 + 1);  // seven arrows and the legend's swatch
    EXPECT_TRUE(std::regex_search(svg, std::regex("<text [^>]*>source</text>")));
    // The detector is labelled with its object name, in the detector's red.
    EXPECT_TRUE(
        std::regex_search(svg, std::regex("<text [^>]*fill=\"#d62728\"[^>]*>sensor</text>")));
    EXPECT_TRUE(
        std::regex_search(svg, std::regex("<text [^>]*>Long focus &amp; &lt;sun&gt;</text>")));
    // The frame takes in where the arrows start.
    for (const LayoutSource::Arrow& a : o.sources[0].arrows) {
        EXPECT_GE(a.fromZY.x, pic.zMin());
        EXPECT_LE(a.fromZY.y, pic.yMax());
    }
}

TEST(DrawLayout, AFarSourceIsClippedNotFramed) {
    const Prepared r = prepare(kSunScene);
    LayoutSource far;
    far.name = "far";
    far.kind = "point";
    far.emitterZY = {Vec2(-1e5, 0.0)};
    far.arrows = {{Vec2(-1e5, 0.0), Vec2(0.0, 10.0)}};
    LayoutOptions o;
    o.sources = {far};
    const Picture with = drawLayout(r.setup->scene, o);
    const Picture without = drawLayout(r.setup->scene, {});
    const double extent =
        std::max(without.zMax() - without.zMin(), without.yMax() - without.yMin());
    EXPECT_LT(with.zMin(), without.zMin());
    EXPECT_GT(with.zMin(), without.zMin() - 0.6 * extent);
    // The arrow is drawn from the frame's edge; the label sits at that start.
    const std::string svg = with.svg();
    EXPECT_TRUE(std::regex_search(svg, std::regex("<text [^>]*>far \\(point\\)</text>")));
    EXPECT_EQ(svg.find("<circle"), std::string::npos);  // the dot itself is outside
}

TEST(DrawLayout, WritesPicturesOfTheExampleSources) {
    const std::filesystem::path dir = scratchDir();
    for (const std::filesystem::path& scene :
         {std::filesystem::path(kSunScene), std::filesystem::path(kWindowScene),
          threeSourceScene()}) {
        const Prepared r = prepare(scene);
        LayoutOptions o;
        o.title = r.file.prescription.system.name;
        o.sources = layoutSources(r.trace.view.sources, r.setup->scene);
        const Picture pic = drawLayout(r.setup->scene, o);
        const std::filesystem::path stem = dir / scene.stem();
        pic.writeSvg(stem.string() + ".svg");
        pic.writePng(stem.string() + ".png", 1600);
        cairo_surface_t* s = cairo_image_surface_create_from_png((stem.string() + ".png").c_str());
        EXPECT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS) << scene;
        EXPECT_EQ(cairo_image_surface_get_width(s), 1600);
        cairo_surface_destroy(s);
    }
}

}  // namespace
}  // namespace veil
