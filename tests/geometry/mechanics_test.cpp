// Mechanics for every example lens, checked with oracles that do not share the builder's
// code: mesh validity (CGAL), volumes against Pappus times the polygon factor, glass
// clearance by testing every mesh vertex and triangle centroid against the lens faces'
// exact sags (the lens solid's convention: exact to sd, flat out to the element radius),
// and part against part with CGAL. Collisions forced on purpose name both parts.

#include "geometry/mechanics.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "geometry/mesh_check.h"
#include "geometry/numerics.h"
#include "geometry/revolve.h"
#include "geometry/surface_frames.h"
#include "geometry/surface_shape.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_document.h"
#include "tests/test_lenses.h"

namespace veil {
namespace {

using ::testing::AllOf;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;
namespace fs = std::filesystem;

fs::path lensPath(const std::string& name) {
    return fs::path(VEIL_SOURCE_DIR) / "examples" / "lenses" / name;
}

Prescription lens(const std::string& name) {
    return readLensFile(lensPath(name), GlassCatalog::builtIn());
}

const MechanicalPart* findPart(const std::vector<MechanicalPart>& parts, const std::string& name) {
    for (const MechanicalPart& p : parts)
        if (p.name == name) return &p;
    return nullptr;
}

std::vector<std::string> names(const std::vector<MechanicalPart>& parts) {
    std::vector<std::string> out;
    for (const MechanicalPart& p : parts) out.push_back(p.name);
    return out;
}

template <class F>
ModelError modelErrorOf(F&& body) {
    try {
        body();
    } catch (const ModelError& e) {
        return e;
    }
    ADD_FAILURE() << "expected a ModelError";
    return ModelError("none", "none");
}

// Oracle: the deepest point of `mesh` inside any lens element, by the lens solid's
// convention (faces exact up to sd, flat at the rim out to the element's radius R). Vertices,
// triangle centroids and edge midpoints are tested; returns the depth (<= 0: clear) and the
// element.
struct GlassHit {
    double depth = -1e300;
    std::string element;
    Vec3 where{0.0};
};

GlassHit deepestInGlass(const Prescription& rx, const TriangleMesh& mesh) {
    std::vector<double> z(rx.surfaces.size(), 0.0);
    for (size_t i = 1; i + 1 < rx.surfaces.size(); ++i)
        z[i + 1] = z[i] + rx.surfaces[i].thicknessMm;
    auto faceZ = [&](int s, double r) {
        const Surface& su = rx.surfaces[s];
        const SurfaceShape shape = makeShape(su.curvature, su.conic, su.asphere);
        const double c = su.clearSemiDiameterMm;
        return z[s] + sag(shape, std::pow(std::min(r, c), 2));
    };
    GlassHit worst;
    auto test = [&](const Vec3& p) {
        const double r = std::hypot(p.x, p.y);
        for (const Element& e : rx.elements()) {
            const double R = std::max({rx.surfaces[e.frontSurface].mechSemiDiameterMm,
                                       rx.surfaces[e.backSurface].mechSemiDiameterMm,
                                       rx.surfaces[e.frontSurface].clearSemiDiameterMm,
                                       rx.surfaces[e.backSurface].clearSemiDiameterMm});
            if (r > R) continue;
            const double a = faceZ(e.frontSurface, r), b = faceZ(e.backSurface, r);
            const double d = std::min({p.z - std::min(a, b), std::max(a, b) - p.z, R - r});
            if (d > worst.depth) worst = {d, e.name, p};
        }
    };
    for (const Vec3& v : mesh.vertices) test(v);
    for (const auto& t : mesh.triangles) {
        const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
        test((a + b + c) / 3.0);
        // Edge midpoints: the chords of a ring come closest to the axis there.
        test(0.5 * (a + b));
        test(0.5 * (b + c));
        test(0.5 * (c + a));
    }
    return worst;
}

double polygonFactor(int n) { return n * std::sin(2.0 * kPi / n) / (2.0 * kPi); }

// Every Example Lens

TEST(Mechanics, EveryExampleLensGetsValidPartsClearOfGlassAndEachOther) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(fs::path(VEIL_SOURCE_DIR) / "examples/lenses"))
        if (entry.path().extension() == ".toml") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    ASSERT_GE(files.size(), 6u);
    for (const fs::path& file : files) {
        SCOPED_TRACE(file.filename().string());
        const Prescription rx = readLensFile(file, GlassCatalog::builtIn());
        // A lens a coordinate break takes off the axis (the Newtonian's fold) gets no mounts:
        // the generator says so, naming the surface, rather than mount it where it is not.
        if (firstSurfaceOffAxis(rx, surfaceFrames(rx)) >= 0) {
            EXPECT_THROW(buildMechanics(rx, MechanicsSpec{}), ModelError);
            continue;
        }
        // Nor does an anamorphic one (the anamorphic imager's cylinders): its rims are curves.
        if (const int a = rx.firstAnamorphic(); a >= 0) {
            try {
                buildMechanics(rx, MechanicsSpec{});
                ADD_FAILURE() << "no error";
            } catch (const ModelError& e) {
                EXPECT_EQ(e.object(), "mechanics");
                EXPECT_NE(std::string(e.what()).find(rx.surfaces[a].name + " is toroidal"),
                          std::string::npos)
                    << e.what();
            }
            continue;
        }
        std::vector<std::string> notes;
        const auto t0 = std::chrono::steady_clock::now();
        const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{}, &notes);
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        ASSERT_FALSE(parts.empty());
        EXPECT_EQ(parts.front().name, "barrel");
        EXPECT_NE(findPart(parts, "stop"), nullptr);
        size_t triangles = 0;
        for (const MechanicalPart& p : parts) {
            SCOPED_TRACE(p.name);
            triangles += p.mesh.triangles.size();
            const MeshCheck c = checkMesh(p.mesh);
            EXPECT_TRUE(c.valid()) << c;
            EXPECT_NEAR(c.volumeMm3, profileRevolvedVolume(p.profile) * polygonFactor(p.segments),
                        1e-9 * c.volumeMm3);
            // The named ranges cover the mesh exactly once.
            uint32_t next = 0;
            for (const NamedTriangleRange& r : p.namedRanges) {
                EXPECT_EQ(r.firstTriangle, next);
                next += r.triangleCount;
            }
            EXPECT_EQ(next, p.mesh.triangles.size());
            const GlassHit g = deepestInGlass(rx, p.mesh);
            EXPECT_LE(g.depth, 0.0) << "inside " << g.element << " at " << g.where;
        }
        for (size_t i = 0; i < parts.size(); ++i)
            for (size_t j = i + 1; j < parts.size(); ++j)
                EXPECT_FALSE(meshesIntersect(parts[i].mesh, parts[j].mesh))
                    << parts[i].name << " / " << parts[j].name;
        std::cout << "[ mech     ] " << file.filename().string() << ": " << parts.size()
                  << " parts, " << triangles << " triangles, N = " << parts.front().segments
                  << ", built and checked in " << std::lround(ms) << " ms:";
        for (const MechanicalPart& p : parts) std::cout << " " << p.name;
        std::cout << "\n";
        for (const std::string& n : notes) std::cout << "[ mech     ]   " << n << "\n";
    }
}

TEST(Mechanics, DoubleGaussStack) {
    const Prescription rx = lens("double_gauss_50mm.toml");
    const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{});
    const std::vector<std::string> n = names(parts);
    for (const char* expected : {"barrel", "retainer1", "retainer2", "spacer1", "spacer5", "stop"})
        EXPECT_NE(std::find(n.begin(), n.end(), expected), n.end()) << expected;
    // The stop splits the air space behind the cemented L2+L3 into spacer3a / spacer3b; no
    // spacer inside the cemented groups.
    EXPECT_EQ(findPart(parts, "spacer2"), nullptr);
    EXPECT_EQ(findPart(parts, "spacer4"), nullptr);
    EXPECT_EQ(findPart(parts, "spacer3"), nullptr);
    // The barrel's bore steps: a seat per lens group.
    const MechanicalPart* barrel = findPart(parts, "barrel");
    ASSERT_NE(barrel, nullptr);
    std::set<double> bores;
    for (const Vec2& v : barrel->profile) bores.insert(v.x);
    EXPECT_GE(bores.size(), 4u);  // the outer wall and at least three bore radii
    // Spacer inner radii leave the beam free: at least the larger facing clear radius.
    const MechanicalPart* s1 = findPart(parts, "spacer1");
    ASSERT_NE(s1, nullptr);
    EXPECT_GE(s1->profile[0].x, 12.6);  // L1.back sd 12.6 > L2.front sd 11.9
}

// Stop

// A size that leaves a part's cross-section degenerate (a knife edge of 1e-320 mm) names the
// part, not the internal function that found it ("revolveProfile: ...").
TEST(Mechanics, ADegenerateCrossSectionNamesThePart) {
    MechanicsSpec spec;
    spec.stop.edgeMm = 1e-320;
    const ModelError e =
        modelErrorOf([&] { buildMechanics(lens("double_gauss_50mm.toml"), spec); });
    EXPECT_EQ(e.object(), "stop");
    EXPECT_THAT(e.what(), HasSubstr("its cross-section cannot be built from the sizes given"));
    EXPECT_THAT(e.what(), Not(HasSubstr("revolveProfile")));
}

TEST(Mechanics, StopEdgeIsExactlyEdgeMmWide) {
    const Prescription rx = lens("double_gauss_50mm.toml");
    for (double edge : {0.05, 0.1, 0.013}) {
        MechanicsSpec spec;
        spec.stop.edgeMm = edge;
        const std::vector<MechanicalPart> parts = buildMechanics(rx, spec);
        const MechanicalPart* stop = findPart(parts, "stop");
        ASSERT_NE(stop, nullptr);
        ASSERT_EQ(stop->namedRanges.size(), 2u);
        EXPECT_EQ(stop->namedRanges[0].name, "stop");
        EXPECT_EQ(stop->namedRanges[1].name, "stop.edge");
        const NamedTriangleRange& er = stop->namedRanges[1];
        EXPECT_EQ(er.triangleCount, 2u * stop->segments);
        const double sd = rx.surfaces[rx.stopIndex()].clearSemiDiameterMm;
        double zMin = 1e300, zMax = -1e300;
        for (uint32_t t = er.firstTriangle; t < er.firstTriangle + er.triangleCount; ++t)
            for (uint32_t v : stop->mesh.triangles[t]) {
                const Vec3 p = stop->mesh.vertices[v];
                EXPECT_NEAR(std::hypot(p.x, p.y), sd, 1e-12);
                zMin = std::min(zMin, p.z);
                zMax = std::max(zMax, p.z);
            }
        EXPECT_NEAR(zMax - zMin, edge, 1e-12) << edge;
        // Centred on the stop plane (the stop surface is flat, at z = 16.885).
        EXPECT_NEAR(0.5 * (zMax + zMin), 3.76 + 0.12 + 4.025 + 3.275 + 5.705, 1e-12);
        // Everything else of the plate lies outside the edge radius.
        for (const Vec2& v : stop->profile) EXPECT_GE(v.x, sd);
    }
}

TEST(Mechanics, StopOnALensFaceSitsOnTheAirSide) {
    // The singlet with its stop flag moved onto L1.front (no separate diaphragm).
    Prescription rx = lens("singlet.toml");
    rx.surfaces.erase(rx.surfaces.begin() + 1);
    rx.surfaces[1].stop = true;
    rx.surfaces[1].clearSemiDiameterMm = 10.0;
    rx.surfaces[1].name.clear();
    rx.surfaces[2].name.clear();
    rx.assignNames();
    rx.validate();
    const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{});
    const MechanicalPart* stop = findPart(parts, "stop");
    ASSERT_NE(stop, nullptr);
    // The knife edge (the closing profile edge) sits just in front of L1.front's rim at the
    // stop's radius: light comes from -z.
    const Vec2 top = stop->profile.back(), bottom = stop->profile.front();
    ASSERT_EQ(top.x, 10.0);
    ASSERT_EQ(bottom.x, 10.0);
    // In front of the face at the stop radius, closer than the plate's half thickness (the
    // bevel keeps clear of the face curving away).
    const double rim = sag(makeShape(1.0 / 59.26, 0.0, {}), 100.0);
    EXPECT_LT(top.y, rim);
    EXPECT_GT(top.y, rim - 0.25);
    EXPECT_LE(deepestInGlass(rx, stop->mesh).depth, 0.0);
}

// A free stop whose neighbour reaches into the plate's place (a face concave toward it that
// crosses the stop plane inside the plate's radii): the plate goes against that face, moved
// along the axis as little as keeps the contact gap, clear of the glass, and a note says by
// how much.
TEST(Mechanics, StopPlateMovesOffAFaceThatReachesItsPlane) {
    Prescription rx = lens("singlet.toml");
    rx.surfaces[2].curvature = -1.0 / 25.0;  // L1.front concave: 2.1 mm deep at r = 10
    rx.validate();
    std::vector<std::string> notes;
    const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{}, &notes);
    const MechanicalPart* stop = findPart(parts, "stop");
    ASSERT_NE(stop, nullptr);
    EXPECT_LE(deepestInGlass(rx, stop->mesh).depth, 0.0);
    // The stop plane is z = 0 and L1.front's vertex z = 1; its rim at r = 10.5 lies 1.32 mm
    // before the plane, and the plate's knife edge now just in front of that.
    const double rim = 1.0 + sag(makeShape(-1.0 / 25.0, 0.0, {}), 10.5 * 10.5);
    EXPECT_LT(stop->profile.back().y, rim);
    EXPECT_GT(stop->profile.back().y, rim - 0.5);
    ASSERT_FALSE(notes.empty());
    EXPECT_THAT(notes, Contains(HasSubstr("stop: L1 reaches into the stop plate's place")));
    EXPECT_THAT(notes, Contains(HasSubstr("the plate is moved")));
    for (const std::string& n : notes) EXPECT_NE(n.rfind(kMechanicsWarning, 0), 0u) << n;
}

// A stop on a face whose neighbour leaves no room for a plate (a plano-concave 0.02 mm in
// front of L1.front, of the same curvature): no plate is built, and a warning says so and what
// limits the light instead.
TEST(Mechanics, StopPlateWithNoRoomIsLeftOutWithAWarning) {
    Prescription rx = lens("singlet.toml");
    rx.surfaces.erase(rx.surfaces.begin() + 1);  // the stop onto L1.front, as above
    rx.surfaces[1].stop = true;
    rx.surfaces[1].clearSemiDiameterMm = 10.0;
    Surface front = rx.surfaces[1], back = rx.surfaces[1];
    front.stop = back.stop = false;
    front.curvature = 0.0;
    front.thicknessMm = 2.0;
    front.material = Material::catalog("N-BK7");
    back.thicknessMm = 0.02;
    back.material = Material::air();
    rx.surfaces.insert(rx.surfaces.begin() + 1, {front, back});
    for (Surface& su : rx.surfaces) su.name.clear();
    rx.assignNames();
    rx.validate();
    std::vector<std::string> notes;
    const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{}, &notes);
    EXPECT_EQ(findPart(parts, "stop"), nullptr);
    EXPECT_THAT(notes, Contains(AllOf(StartsWith(std::string(kMechanicsWarning)),
                                      HasSubstr("no plate fits between L2 and L1"),
                                      HasSubstr("no stop plate is built"))));
    for (const MechanicalPart& p : parts)
        EXPECT_LE(deepestInGlass(rx, p.mesh).depth, 0.0) << p.name;
}

// Two elements whose air gap leaves no axial room for a seat: the second's concave front face
// reaches past the first's rim (US 8,427,765's L3 and L4: 0.22 mm of air on the axis, 0.02 mm
// at r = 7). The barrel steps once, from the first's bore to the second's, in front of the
// second's rim, instead of a seat pushed into its glass.
TEST(Mechanics, BarrelStepsOnceWhereNoSeatFitsBetweenTwoElements) {
    const fs::path file = fs::path(::testing::TempDir()) / "veil_mechanics_no_seat.toml";
    {
        std::ofstream out(file);
        out << "[system]\nwavelengths_nm = [587.5618]\naperture = { f_number = 4.0 }\n"
               "fields_deg = [0.0, 5.0]\nsurfaces = [\n"
               "  { stop = true, t = 5.0, sd = 4.0 },\n"
               "  { r = 30.0, t = 2.0, glass = \"N-BK7\", sd = 6.0, mech_sd = 7.0 },\n"
               "  { r = -53.59, t = 0.22, sd = 7.0 },\n"
               "  { r = -37.47, t = 3.6, glass = \"N-BK7\", sd = 7.53, mech_sd = 8.3 },\n"
               "  { r = -11.763, t = 20.0, sd = 8.3 },\n]\n";
    }
    const Prescription rx = readLensFile(file, GlassCatalog::builtIn());
    const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{});
    const MechanicalPart* barrel = findPart(parts, "barrel");
    ASSERT_NE(barrel, nullptr);
    const GlassHit g = deepestInGlass(rx, barrel->mesh);
    EXPECT_LE(g.depth, 0.0) << "inside " << g.element << " at " << g.where;
    // One step between the two bores: no bore between 7.05 and 8.35 mm.
    for (const Vec2& v : barrel->profile)
        if (v.x > 7.06 && v.x < 8.34) ADD_FAILURE() << "a seat at r = " << v.x << ", z = " << v.y;
}

// An achromatic Mangin (ray-optics' achroMangin_ok.seq, tests/data/README.md): a cemented
// doublet whose back is the mirror, so the light crosses both elements again on its way out.
// The way back through the front element is the same glass, not a third body: its smaller
// semi-diameters (the returning beam is narrower) had set the barrel's bore inside the
// mirror's rim (0.16 mm deep at r = 2.661 mm).
TEST(Mechanics, ACementedManginsWayBackIsNoBodyOfItsOwn) {
    Prescription rx = readLensFile(VEIL_SOURCE_DIR "/tests/data/codev/achroMangin_ok.seq",
                                   GlassCatalog::builtIn());
    // The semi-diameters veil traces for the file's beam (veil info).
    const double sd[] = {0.0, 2.5, 2.5813, 2.6614, 2.4525, 2.2618};
    for (int i = 1; i <= 5; ++i) rx.surfaces[i].clearSemiDiameterMm = sd[i];
    const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{});
    const MechanicalPart* barrel = findPart(parts, "barrel");
    ASSERT_NE(barrel, nullptr);
    const GlassHit g = deepestInGlass(rx, barrel->mesh);
    EXPECT_LE(g.depth, 0.0) << "inside " << g.element << " at " << g.where;
}

// A lens of nothing but its stop (and dummy surfaces: other projects' coordinate-break test
// files) gives the mount generator nothing to size a barrel by: a model error that says so.
// It crashed before (an end region's bore read from a body that did not exist).
TEST(Mechanics, ALensWithNothingToHoldIsAModelError) {
    const fs::path file = fs::path(::testing::TempDir()) / "veil_mechanics_stop_only.toml";
    std::ofstream(file) << "[system]\naperture = { epd_mm = 10 }\nsurfaces = [\n"
                           "  { stop = true, t = 10, sd = 5 },\n  { r = 0, t = 20 },\n]\n";
    const Prescription rx = readLensFile(file, GlassCatalog::builtIn());
    const ModelError e = modelErrorOf([&] { buildMechanics(rx, MechanicsSpec{}); });
    EXPECT_EQ(e.object(), "mechanics");
    EXPECT_THAT(e.what(), HasSubstr("no lens element or mirror for the mount generator to hold"));
}

TEST(Mechanics, StopWithoutSemiDiameterIsAModelErrorNamingIt) {
    Prescription rx = lens("double_gauss_50mm.toml");
    rx.surfaces[rx.stopIndex()].clearSemiDiameterMm = 0.0;
    const ModelError e = modelErrorOf([&] { buildMechanics(rx, MechanicsSpec{}); });
    EXPECT_EQ(e.object(), "stop");
    EXPECT_THAT(e.what(), HasSubstr("clear semi-diameter"));
}

TEST(Mechanics, StopThicknessItsBevelsCannotReachIsAModelError) {
    // The double Gauss's stop plate is 2.64 mm wide (8.608 to 11.249 mm): 45 deg bevels
    // cannot grow it to 6 mm.
    MechanicsSpec spec;
    spec.stop.thicknessMm = 6.0;
    const ModelError e =
        modelErrorOf([&] { buildMechanics(lens("double_gauss_50mm.toml"), spec); });
    EXPECT_EQ(e.object(), "stop");
    EXPECT_THAT(e.what(), HasSubstr("too thick"));
}

// Placement

TEST(Mechanics, RingsRestOnTheExactSagOverTheirMeshRadii) {
    // Singlet: stop plate at z = 0, spacer0, L1 (front r = 59.26 mm at z = 1, sd 10.5, flat
    // beyond; back r = -394.56 mm at z = 5), retainer2.
    const Prescription rx = lens("singlet.toml");
    MechanicsSpec spec;
    const std::vector<MechanicalPart> parts = buildMechanics(rx, spec);
    const MechanicalPart* s0 = findPart(parts, "spacer0");
    ASSERT_NE(s0, nullptr);
    // spacer0's inner radius is L1.front's sd (> the stop's 10.0). The convex front face
    // rises with r, so its lowest point under the spacer is at the spacer mesh's smallest
    // radius, the chord midpoint rin cos(pi / N), not at rin.
    const double rin = s0->profile[0].x;
    EXPECT_EQ(rin, 10.5);
    const double rMesh = rin * std::cos(kPi / s0->segments);
    const SurfaceShape front = makeShape(1.0 / 59.26, 0.0, {});
    EXPECT_NEAR(s0->profile[2].y, 1.0 + sag(front, rMesh * rMesh) - spec.contactGapMm, 1e-9);
    EXPECT_LT(s0->profile[2].y, 1.0 + sag(front, rin * rin) - spec.contactGapMm - 1e-6);
    // retainer2 sits on L1.back's flat shoulder, at the height of the face at its sd.
    const MechanicalPart* r2 = findPart(parts, "retainer2");
    ASSERT_NE(r2, nullptr);
    EXPECT_NEAR(r2->profile[0].x, 10.5 + spec.retainers.widthMm * std::tan(5.0 * kPi / 180.0),
                1e-12);
    const SurfaceShape back = makeShape(1.0 / -394.56, 0.0, {});
    EXPECT_NEAR(r2->profile[0].y, 5.0 + sag(back, 10.5 * 10.5) + spec.contactGapMm, 1e-9);
}

// Collisions

TEST(Mechanics, CollisionsNameBothParts) {
    const Prescription rx = lens("double_gauss_50mm.toml");
    {
        // A stop plate far too thick for the 3.5 mm between the flats of L3 and L4.
        MechanicsSpec spec;
        spec.stop.thicknessMm = 5.0;
        const ModelError e = modelErrorOf([&] { buildMechanics(rx, spec); });
        EXPECT_EQ(e.object(), "stop");
        EXPECT_THAT(e.what(), HasSubstr("collides with L"));
        EXPECT_THAT(e.what(), HasSubstr("at r = "));
        std::cout << "[ collide  ] " << e.what() << "\n";
    }
    {
        // A clearance smaller than the chord error: the bore's chords cut into a lens rim.
        MechanicsSpec spec;
        spec.chordToleranceMm = 0.05;
        spec.barrel.clearanceMm = 0.001;
        const ModelError e = modelErrorOf([&] { buildMechanics(rx, spec); });
        EXPECT_EQ(e.object(), "barrel");
        EXPECT_THAT(e.what(), HasSubstr("collides with L"));
        std::cout << "[ collide  ] " << e.what() << "\n";
    }
    {
        // A baffle placed in the middle of L6 (z 28.8 to 32.0).
        MechanicsSpec spec;
        spec.baffles.push_back({true, 30.4, 5.0, 0.5, ""});
        const ModelError e = modelErrorOf([&] { buildMechanics(rx, spec); });
        EXPECT_EQ(e.object(), "baffle1");
        EXPECT_THAT(e.what(), HasSubstr("collides with L6"));
        std::cout << "[ collide  ] " << e.what() << "\n";
    }
    {
        // A baffle on top of the stop plate: part against part (CGAL).
        MechanicsSpec spec;
        spec.baffles.push_back({true, 16.885, 9.0, 0.2, ""});
        const ModelError e = modelErrorOf([&] { buildMechanics(rx, spec); });
        EXPECT_THAT(e.what(), HasSubstr("stop"));
        EXPECT_THAT(e.what(), HasSubstr("baffle1"));
        std::cout << "[ collide  ] " << e.what() << "\n";
    }
}

// Folded Systems

TEST(Mechanics, MirrorSystemsBuildWhatMakesSense) {
    {
        // The Cassegrain of docs/format.md: mirrors only, the stop on the primary. The light
        // crosses the tube twice: no spacers or retainers; a tube clear of the primary, and
        // the stop plate in front of the primary's rim.
        Prescription rx = test::startLens(kInfinity, 100.0);
        Surface m1 = test::surface(-400.0, -150.0);
        m1.mirror = true;
        m1.conic = -1.0;
        m1.clearSemiDiameterMm = 50.0;
        Surface m2 = test::surface(-150.0, 180.0);
        m2.mirror = true;
        m2.conic = -2.5;
        m2.clearSemiDiameterMm = 15.0;
        rx.surfaces.push_back(m1);
        rx.surfaces.push_back(m2);
        test::finishLens(rx);
        std::vector<std::string> notes;
        const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{}, &notes);
        EXPECT_EQ(names(parts), (std::vector<std::string>{"barrel", "stop"}));
        for (const MechanicalPart& p : parts) EXPECT_TRUE(checkMesh(p.mesh).valid()) << p.name;
        ASSERT_EQ(parts.size(), 2u);
        double boreMin = 1e300;
        for (const Vec2& v : parts[0].profile) boreMin = std::min(boreMin, v.x);
        EXPECT_GT(boreMin, 50.0);
        // The primary's rim is at z = -3.125 (paraboloid, r = 50); light comes from -z.
        double stopZMax = -1e300;
        for (const Vec2& v : parts[1].profile) stopZMax = std::max(stopZMax, v.y);
        EXPECT_LT(stopZMax, -3.125);
        for (const std::string& s : notes) std::cout << "[ mech     ]   cassegrain: " << s << "\n";
    }
    {
        // A Mangin mirror: glass, a silvered back, and back out through the front face.
        Prescription rx = test::startLens(kInfinity, 20.0);
        Surface front = test::surface(-100.0, 5.0, Material::catalog("N-BK7"));
        front.clearSemiDiameterMm = 12.0;
        Surface back = test::surface(-200.0, -5.0, Material::catalog("N-BK7"));
        back.mirror = true;
        back.clearSemiDiameterMm = 12.0;
        Surface out = test::surface(-100.0, -60.0);
        out.clearSemiDiameterMm = 12.0;
        rx.surfaces.push_back(front);
        rx.surfaces.push_back(back);
        rx.surfaces.push_back(out);
        test::finishLens(rx);
        const std::vector<MechanicalPart> parts = buildMechanics(rx, MechanicsSpec{});
        EXPECT_NE(findPart(parts, "barrel"), nullptr);
        EXPECT_NE(findPart(parts, "stop"), nullptr);
        for (const MechanicalPart& p : parts) {
            EXPECT_TRUE(checkMesh(p.mesh).valid()) << p.name;
            EXPECT_LE(deepestInGlass(rx, p.mesh).depth, 0.0) << p.name;
        }
    }
}

// Optional Parts

TEST(Mechanics, FieldStopBafflesAndVanes) {
    {
        const Prescription rx = lens("double_gauss_50mm.toml");
        MechanicsSpec spec;
        spec.fieldStop.enabled = true;
        spec.fieldStop.radiusMm = 21.7;
        spec.baffles.push_back({true, 50.0, 14.0, 0.5, "black"});
        const std::vector<MechanicalPart> parts = buildMechanics(rx, spec);
        const MechanicalPart* fs = findPart(parts, "field_stop");
        ASSERT_NE(fs, nullptr);
        double zMid = 0.0;
        for (const Vec2& v : fs->profile) zMid += v.y / fs->profile.size();
        const double image =
            3.76 + 0.12 + 4.025 + 3.275 + 5.705 + 4.5 + 1.18 + 6.065 + 0.19 + 3.22 + 35.72;
        EXPECT_NEAR(zMid, image - 1.0, 1e-9);
        EXPECT_EQ(fs->profile.front().x, 21.7);
        const MechanicalPart* b = findPart(parts, "baffle1");
        ASSERT_NE(b, nullptr);
        EXPECT_EQ(b->property, "black");
        // The barrel reaches the field stop.
        double zEnd = -1e300;
        for (const Vec2& v : findPart(parts, "barrel")->profile) zEnd = std::max(zEnd, v.y);
        EXPECT_GT(zEnd, image - 1.0);
    }
    {
        // Vanes along the catadioptric's tube, between the secondary and the primary.
        const Prescription rx = lens("catadioptric_2000mm.toml");
        MechanicsSpec spec;
        spec.vanes = {true, 7, 2.0, 0.5, 100.0, 400.0, ""};
        std::vector<std::string> notes;
        const std::vector<MechanicalPart> parts = buildMechanics(rx, spec, &notes);
        for (int i = 1; i <= 7; ++i)
            EXPECT_NE(findPart(parts, "vane" + std::to_string(i)), nullptr) << i;
        const MechanicalPart* v1 = findPart(parts, "vane1");
        ASSERT_NE(v1, nullptr);
        // On the tube's bore, which clears the primary mirror (mech_sd 112).
        EXPECT_GT(v1->profile.front().x + 2.0, 112.0);
    }
}

TEST(Mechanics, UserPartsAreRevolvedAsDrawnAndChecked) {
    // The catadioptric: L1's back face at z = 41 (R -273.66), M2 at z = 61 (R -501.53,
    // mech_sd 40). A conical tube in front of the primary, drawn clockwise, and a disc between
    // the corrector and the secondary.
    const Prescription rx = lens("catadioptric_2000mm.toml");
    MechanicsSpec spec;
    spec.property = "mount";
    const std::vector<Vec2> tube{{29.0, 455.0}, {30.0, 455.0}, {33.0, 350.0}, {32.0, 350.0}};
    spec.parts.push_back({true, "tube", tube, ""});
    spec.parts.push_back(
        {true, "disc", {{0.0, 45.0}, {30.0, 45.0}, {30.0, 55.0}, {0.0, 55.0}}, "black"});
    spec.parts.push_back({false, "off", {{0.0, 45.0}, {1.0, 45.0}, {1.0, 46.0}}, ""});
    std::vector<MechanicalPart> parts = buildMechanics(rx, spec);
    ASSERT_GE(parts.size(), 2u);
    EXPECT_EQ(parts[parts.size() - 2].name, "tube");  // last, in the order given
    EXPECT_EQ(parts.back().name, "disc");
    EXPECT_EQ(findPart(parts, "off"), nullptr);
    const MechanicalPart& t = parts[parts.size() - 2];
    EXPECT_EQ(t.property, "mount");  // the [mechanics] property
    EXPECT_EQ(parts.back().property, "black");
    // Revolved counter-clockwise: the same outline, reversed.
    EXPECT_EQ(t.profile, std::vector<Vec2>(tube.rbegin(), tube.rend()));
    for (const MechanicalPart* p : {&t, static_cast<const MechanicalPart*>(&parts.back())}) {
        const MeshCheck c = checkMesh(p->mesh);
        EXPECT_TRUE(c.valid()) << p->name;
        EXPECT_NEAR(c.volumeMm3, profileRevolvedVolume(p->profile) * polygonFactor(p->segments),
                    1e-9 * c.volumeMm3)
            << p->name;
        EXPECT_LE(deepestInGlass(rx, p->mesh).depth, 0.0) << p->name;
        ASSERT_EQ(p->namedRanges.size(), 1u);
        EXPECT_EQ(p->namedRanges[0].triangleCount, p->mesh.triangles.size());
    }
    // A part wider than the barrel sets the segment count: the chord error stays within the
    // tolerance at its radius.
    spec.parts = {
        {true, "shade", {{300.0, -50.0}, {302.0, -50.0}, {302.0, -20.0}, {300.0, -20.0}}, ""}};
    parts = buildMechanics(rx, spec);
    const MechanicalPart* shade = findPart(parts, "shade");
    ASSERT_NE(shade, nullptr);
    EXPECT_LE(chordError(302.0, shade->segments), spec.chordToleranceMm);
    for (const MechanicalPart& p : parts) EXPECT_EQ(p.segments, shade->segments) << p.name;

    // Into the glass, into a mirror, into another part, or a built part's name: ModelErrors
    // naming the part.
    auto failing = [&](MechanicsSpec::Part part) {
        MechanicsSpec bad;
        bad.parts = {std::move(part)};
        return modelErrorOf([&] { buildMechanics(rx, bad); });
    };
    ModelError e =
        failing({true, "plug", {{0.0, 30.0}, {20.0, 30.0}, {20.0, 50.0}, {0.0, 50.0}}, ""});
    EXPECT_EQ(e.object(), "plug");
    EXPECT_THAT(e.what(), HasSubstr("collides with L1"));
    e = failing({true, "cup", {{0.0, 45.0}, {30.0, 45.0}, {30.0, 62.0}, {0.0, 62.0}}, ""});
    EXPECT_EQ(e.object(), "cup");
    EXPECT_THAT(e.what(), HasSubstr("collides with"));
    std::cout << "[ collide  ] " << e.what() << "\n";
    e = failing({true, "barrel", {{0.0, 45.0}, {30.0, 45.0}, {30.0, 55.0}, {0.0, 55.0}}, ""});
    EXPECT_EQ(e.object(), "barrel");
    EXPECT_THAT(e.what(), HasSubstr("already used"));
    MechanicsSpec two;
    two.parts = {{true, "a", {{0.0, 45.0}, {30.0, 45.0}, {30.0, 55.0}, {0.0, 55.0}}, ""},
                 {true, "b", {{10.0, 50.0}, {35.0, 50.0}, {35.0, 56.0}, {10.0, 56.0}}, ""}};
    e = modelErrorOf([&] { buildMechanics(rx, two); });
    EXPECT_THAT(e.what(), HasSubstr("collides with"));
    EXPECT_THAT(std::string(e.what()) + e.object(), HasSubstr("a"));
}

TEST(Mechanics, PartsSwitchedOffAreAbsent) {
    const Prescription rx = lens("double_gauss_50mm.toml");
    auto without = [&](auto change) {
        MechanicsSpec spec;
        change(spec);
        return names(buildMechanics(rx, spec));
    };
    auto has = [](const std::vector<std::string>& n, const std::string& prefix) {
        return std::any_of(n.begin(), n.end(),
                           [&](const std::string& s) { return s.rfind(prefix, 0) == 0; });
    };
    const auto all = without([](MechanicsSpec&) {});
    EXPECT_TRUE(has(all, "barrel") && has(all, "retainer") && has(all, "spacer") &&
                has(all, "stop"));
    const auto noBarrel = without([](MechanicsSpec& s) { s.barrel.enabled = false; });
    EXPECT_FALSE(has(noBarrel, "barrel"));
    EXPECT_TRUE(has(noBarrel, "spacer"));
    const auto noSpacers = without([](MechanicsSpec& s) { s.spacers.enabled = false; });
    EXPECT_FALSE(has(noSpacers, "spacer"));
    const auto noRetainers = without([](MechanicsSpec& s) { s.retainers.enabled = false; });
    EXPECT_FALSE(has(noRetainers, "retainer"));
    // Without the stop plate the air space L3 | L4 holds one spacer.
    const auto noStop = without([](MechanicsSpec& s) { s.stop.enabled = false; });
    EXPECT_FALSE(has(noStop, "stop"));
    EXPECT_NE(std::find(noStop.begin(), noStop.end(), "spacer3"), noStop.end());
    const auto none = without([](MechanicsSpec& s) {
        s.barrel.enabled = s.spacers.enabled = s.retainers.enabled = s.stop.enabled = false;
    });
    EXPECT_TRUE(none.empty());
}

// Tessellation Tolerance

TEST(Mechanics, ChordToleranceTradesTrianglesForVolumeError) {
    // Relative volume error of every part is exactly 1 - N sin(2 pi / N) / (2 pi), about
    // (2 pi / N)^2 / 6 = (4/3) tol / r_max: ten times smaller per decade of tolerance, for
    // sqrt(10) times more triangles.
    const Prescription rx = lens("double_gauss_50mm.toml");
    struct Row {
        double tol;
        int segments;
        size_t triangles;
        double volumeError;
        double ms;
    };
    std::vector<Row> rows;
    for (double tol : {0.1, 0.01, 0.001}) {
        MechanicsSpec spec;
        spec.chordToleranceMm = tol;
        spec.barrel.clearanceMm = 0.15;  // above the coarsest chord error
        const auto t0 = std::chrono::steady_clock::now();
        const std::vector<MechanicalPart> parts = buildMechanics(rx, spec);
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        size_t triangles = 0;
        double exact = 0.0, meshed = 0.0;
        for (const MechanicalPart& p : parts) {
            triangles += p.mesh.triangles.size();
            exact += profileRevolvedVolume(p.profile);
            meshed += checkMesh(p.mesh).volumeMm3;
        }
        const double err = 1.0 - meshed / exact;
        const int n = parts.front().segments;
        EXPECT_NEAR(err, 1.0 - polygonFactor(n), 1e-9);
        // The chord error bound at the barrel's outer radius.
        double rMax = 0.0;
        for (const Vec2& v : parts.front().profile) rMax = std::max(rMax, v.x);
        EXPECT_LE(chordError(rMax, n), tol);
        rows.push_back({tol, n, triangles, err, ms});
    }
    std::cout << "[ chord    ] double Gauss mechanics, by chord_tolerance_mm:\n";
    for (const Row& r : rows)
        std::cout << "[ chord    ]   " << r.tol << " mm: N = " << r.segments << ", " << r.triangles
                  << " triangles, volume error " << r.volumeError * 100.0
                  << " %, built and checked in " << std::lround(r.ms) << " ms\n";
    for (size_t i = 1; i < rows.size(); ++i) {
        EXPECT_NEAR(static_cast<double>(rows[i].triangles) / rows[i - 1].triangles, std::sqrt(10.0),
                    0.15);
        EXPECT_NEAR(rows[i - 1].volumeError / rows[i].volumeError, 10.0, 1.0);
    }
}

TEST(Mechanics, SegmentCountIsBoundedBeforeMeshing) {
    // A tolerance or a radius that would take more than kMaxMechanicsSegments segments per
    // turn is refused, naming the radius, the tolerance and the smallest tolerance that
    // would do; nothing is meshed (the check is immediate, not minutes of meshing).
    const Prescription rx = lens("double_gauss_50mm.toml");
    MechanicsSpec spec;
    spec.chordToleranceMm = 1e-9;
    const ModelError e = modelErrorOf([&] { buildMechanics(rx, spec); });
    EXPECT_EQ(e.object(), "mechanics");
    EXPECT_THAT(e.what(), HasSubstr("the barrel's outside"));
    EXPECT_THAT(e.what(), HasSubstr("at most 4096"));
    EXPECT_THAT(e.what(), HasSubstr("raise chord_tolerance_mm to at least"));
    EXPECT_THAT(e.what(), Not(HasSubstr("chordSegmentCount")));
    // A wall of a kilometre at the default tolerance: 22000 segments asked for.
    spec = MechanicsSpec{};
    spec.barrel.wallMm = 1e6;
    EXPECT_THAT(modelErrorOf([&] { buildMechanics(rx, spec); }).what(), HasSubstr("22"));
    // A baffle of a kilometre's opening: the message names the baffle that widened the
    // barrel, not the barrel.
    spec = MechanicsSpec{};
    spec.baffles.push_back({true, 30.4, 1e6, 0.5, ""});
    const std::string baffle = modelErrorOf([&] { buildMechanics(rx, spec); }).what();
    EXPECT_THAT(baffle, HasSubstr("around baffle1"));
    EXPECT_THAT(baffle, HasSubstr("1000003.000 mm"));  // + 1 mm of plate + 2 mm of wall
    spec = MechanicsSpec{};
    // At the limit's tolerance the same radius builds with at most the limit.
    spec.barrel.wallMm = 100.0;
    spec.chordToleranceMm = 1e-4;
    const std::vector<MechanicalPart> parts = buildMechanics(rx, spec);
    ASSERT_FALSE(parts.empty());
    EXPECT_LE(parts.front().segments, kMaxMechanicsSegments);
    EXPECT_GT(parts.front().segments, kMaxMechanicsSegments / 2);
}

// Reading [mechanics]

// The example of docs/format.md, section [mechanics], read from the document itself.
std::string formatDocMechanicsExample() {
    std::ifstream in(fs::path(VEIL_SOURCE_DIR) / "docs" / "format.md");
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string doc = ss.str();
    const size_t section = doc.find("## `[mechanics]`");
    const size_t begin = doc.find("```toml\n", section);
    const size_t end = doc.find("```\n", begin + 8);
    if (section == std::string::npos || begin == std::string::npos || end == std::string::npos)
        return {};
    return doc.substr(begin + 8, end - begin - 8);
}

TEST(Mechanics, ReadsTheTable) {
    const std::string text = formatDocMechanicsExample();
    ASSERT_FALSE(text.empty()) << "no [mechanics] example in docs/format.md";
    TomlDocument doc = TomlDocument::fromString(text, "scene.toml");
    const std::optional<MechanicsSpec> s = readMechanics(doc);
    ASSERT_TRUE(s.has_value());
    EXPECT_NO_THROW(doc.checkAllUsed());
    EXPECT_EQ(s->chordToleranceMm, 0.02);
    EXPECT_EQ(s->contactGapMm, 0.002);
    EXPECT_EQ(s->property, "black_anodized");
    EXPECT_EQ(s->lensEdgeProperty, "ground_glass");
    EXPECT_EQ(s->barrel.wallMm, 3.0);
    EXPECT_EQ(s->barrel.clearanceMm, 0.03);
    EXPECT_EQ(s->barrel.property, "anodized");
    EXPECT_FALSE(s->retainers.enabled);
    EXPECT_TRUE(s->spacers.enabled);
    EXPECT_EQ(s->spacers.minLengthMm, 0.5);
    EXPECT_EQ(s->stop.edgeMm, 0.02);
    EXPECT_EQ(s->stop.thicknessMm, 0.3);
    EXPECT_EQ(s->stop.bevelDeg, 30.0);
    EXPECT_EQ(s->stop.edgeProperty, "knife");
    EXPECT_TRUE(s->fieldStop.enabled);
    EXPECT_FALSE(s->fieldStop.zMm.has_value());
    EXPECT_EQ(s->fieldStop.beforeImageMm, 2.0);
    EXPECT_TRUE(s->vanes.enabled);
    EXPECT_EQ(s->vanes.count, 4);
    ASSERT_EQ(s->baffles.size(), 2u);
    EXPECT_FALSE(s->baffles[1].enabled);

    // The spec builds: properties reach the parts and the stop's edge.
    const std::vector<MechanicalPart> parts = buildMechanics(lens("double_gauss_50mm.toml"), *s);
    EXPECT_EQ(findPart(parts, "barrel")->property, "anodized");
    EXPECT_EQ(findPart(parts, "stop")->property, "black_anodized");
    EXPECT_EQ(findPart(parts, "stop")->namedRanges[1].property, "knife");
    EXPECT_EQ(findPart(parts, "retainer1"), nullptr);
    EXPECT_NE(findPart(parts, "baffle1"), nullptr);
    EXPECT_EQ(findPart(parts, "baffle2"), nullptr);
    // As the document says.
    EXPECT_EQ(names(parts), (std::vector<std::string>{
                                "barrel", "spacer1", "spacer3a", "spacer3b", "spacer5", "spacer6a",
                                "spacer6b", "spacer6c", "spacer6d", "spacer6e", "spacer6f", "stop",
                                "field_stop", "baffle1", "vane1", "vane2", "vane3", "vane4"}));
}

TEST(Mechanics, NoTableNoMechanics) {
    TomlDocument doc = TomlDocument::fromString("[system]\nname = \"x\"\n", "lens.toml");
    EXPECT_FALSE(readMechanics(doc).has_value());
}

TEST(Mechanics, UnknownKeysAndBadValuesAreParseErrorsAtTheirPlace) {
    {
        TomlDocument doc =
            TomlDocument::fromString("[mechanics]\nbarrel = { wal_mm = 2 }\n", "scene.toml");
        readMechanics(doc);
        try {
            doc.checkAllUsed();
            ADD_FAILURE() << "expected a ParseError";
        } catch (const ParseError& e) {
            EXPECT_EQ(e.loc().line, 2);
            EXPECT_EQ(e.loc().column, 12);
            EXPECT_THAT(e.what(), HasSubstr("wal_mm"));
            EXPECT_THAT(e.what(), HasSubstr("did you mean 'wall_mm'"));
        }
    }
    auto parseError = [](const std::string& text) {
        TomlDocument doc = TomlDocument::fromString(text, "scene.toml");
        try {
            readMechanics(doc);
        } catch (const ParseError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_THAT(parseError("[mechanics]\nchord_tolerance_mm = 0\n"), HasSubstr("scene.toml:2:"));
    EXPECT_THAT(parseError("[mechanics]\nstop = { edge_mm = 0.1, thickness_mm = 0.05 }\n"),
                HasSubstr("at least edge_mm"));
    EXPECT_THAT(parseError("[mechanics]\nstop = { bevel_deg = 90 }\n"), HasSubstr("bevel_deg"));
    EXPECT_THAT(parseError("[mechanics]\nfield_stop = { z_mm = 3 }\n"), HasSubstr("radius_mm"));
    EXPECT_THAT(
        parseError("[mechanics]\nfield_stop = { z_mm = 3, before_image_mm = 1, radius_mm = 2 }\n"),
        HasSubstr("not both"));
    EXPECT_THAT(
        parseError(
            "[mechanics]\nvanes = { count = 2, depth_mm = 1, from_z_mm = 5, to_z_mm = 1 }\n"),
        HasSubstr("to_z_mm"));
    EXPECT_THAT(parseError("[mechanics]\nbarrel = 3\n"), HasSubstr("a table or a boolean"));
    // User parts: the outline must be a simple polygon of [r, z] points with r >= 0.
    auto part = [](const std::string& body) { return "[mechanics]\n[[mechanics.parts]]\n" + body; };
    EXPECT_THAT(parseError(part("name = \"p\"\nprofile_mm = [[0, 0], [1, 0]]\n")),
                HasSubstr("scene.toml:4:"));
    EXPECT_THAT(parseError(part("name = \"p\"\nprofile_mm = [[0, 0], [1, 0]]\n")),
                HasSubstr("at least 3 points"));
    EXPECT_THAT(parseError(part("name = \"p\"\nprofile_mm = [[0, 0], [2, 2], [2, 0], [0, 2]]\n")),
                HasSubstr("not a simple closed outline"));
    EXPECT_THAT(parseError(part("name = \"p\"\nprofile_mm = [[0, 0], [-1, 0], [0, 1]]\n")),
                HasSubstr("scene.toml:4:"));
    EXPECT_THAT(parseError(part("name = \"p\"\nprofile_mm = [[0, 0], [1, 0, 3], [0, 1]]\n")),
                HasSubstr("[r, z]"));
    EXPECT_THAT(parseError(part("name = \"p.q\"\nprofile_mm = [[0, 0], [1, 0], [0, 1]]\n")),
                HasSubstr("without dots"));
    EXPECT_THAT(parseError(part("profile_mm = [[0, 0], [1, 0], [0, 1]]\n")), HasSubstr("name"));
    std::string many = "name = \"p\"\nprofile_mm = [[0, 0]";
    for (size_t i = 1; i <= kMaxPartProfilePoints; ++i)
        many += ", [" + std::to_string(i) + ", " + std::to_string(i % 2) + "]";
    EXPECT_THAT(parseError(part(many + "]\n")), HasSubstr("at most 4096"));
    EXPECT_THAT(parseError(part("name = \"p\"\nprofile_mm = [[0, 0], [1, 0], [0, 1]]\n"
                                "[[mechanics.parts]]\nname = \"p\"\n"
                                "profile_mm = [[0, 0], [1, 0], [0, 1]]\n")),
                HasSubstr("already used at scene.toml:3:"));
    EXPECT_THAT(parseError("[mechanics]\nfield_stop = true\n"), HasSubstr("radius_mm"));
}

}  // namespace
}  // namespace veil
