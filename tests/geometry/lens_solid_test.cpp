// Lens elements as closed solids. The watertightness oracle is brute force: rays from random
// points inside the glass, intersected with every face of the element by a plain loop, must
// leave through one of them, from the glass side; followed through every face of the lens
// (medium by medium, each hit's "from" medium checked against the medium the ray is in) they
// must end in air. Rays aimed exactly at the seams where faces meet check that no crack
// opens there. Names, kinds, media and sizes are checked against the prescription.

#include "geometry/lens_solid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>

#include "geometry/revolve.h"
#include "geometry/scene.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"
#include "tests/test_lenses.h"

namespace veil {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Prescription example(const std::string& name) {
    return readLensFile(std::string(VEIL_SOURCE_DIR) + "/examples/lenses/" + name,
                        GlassCatalog::builtIn());
}

const SceneObject& get(const Scene& scene, const std::string& name) {
    const SceneObject* o = scene.find(name);
    if (!o) throw std::runtime_error("no object " + name);
    return *o;
}

const SurfacePatch& patchOf(const SceneObject& o) {
    return std::get<SurfacePatch>(std::get<FaceGeometry>(o.geometry));
}

// The faces bounding an element: its own parts, and the cemented face it shares with the
// element in front (named after that one, with an alias of this element's).
std::vector<int> facesOf(const Scene& scene, const std::string& element) {
    std::vector<int> ids;
    for (const SceneObject& o : scene.objects()) {
        bool mine = o.part == element;
        for (const std::string& a : o.aliases) mine = mine || a.rfind(element + ".", 0) == 0;
        if (mine) ids.push_back(o.id);
    }
    return ids;
}

struct Hit {
    int object = -1;
    double t = kInf;
    Vec3 normal{0.0};
};

// Closest hit over the given objects by a plain loop, in double, each face in its frame.
Hit firstHit(const Scene& scene, const std::vector<int>& ids, const Ray& ray, int startObject) {
    Hit best;
    for (int id : ids) {
        const SceneObject& o = scene.object(id);
        const auto h = intersectFace(std::get<FaceGeometry>(o.geometry), o.frame.toLocal(ray), 0.0,
                                     best.t, id == startObject);
        if (h && h->t < best.t) {
            best.object = id;
            best.t = h->t;
            best.normal = o.frame.toGlobalDirection(h->normal);
        }
    }
    return best;
}

// The medium a ray meets a face from, and the one behind it.
int mediumFrom(const SceneObject& o, const Vec3& d, const Vec3& normal) {
    return glm::dot(d, normal) < 0.0 ? o.mediumFront : o.mediumBack;
}
int mediumTo(const SceneObject& o, const Vec3& d, const Vec3& normal) {
    return glm::dot(d, normal) < 0.0 ? o.mediumBack : o.mediumFront;
}

Vec3 randomDirection(std::mt19937_64& rng) {
    std::normal_distribution<double> g;
    return glm::normalize(Vec3{g(rng), g(rng), g(rng)});
}

// A random point strictly inside the solid: uniform over the disc of radius R, uniform in z
// between the front and back boundaries there.
Vec3 randomInside(const LensSolid& s, std::mt19937_64& rng) {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const double r = s.edgeRadiusMm * std::sqrt(uni(rng));
    const double phi = 2.0 * std::numbers::pi * uni(rng);
    const double x = r * std::cos(phi), y = r * std::sin(phi);
    const double zf = s.frontZAt(x, y), zb = s.backZAt(x, y);
    double v = uni(rng);
    while (v == 0.0) v = uni(rng);
    return Vec3{x, y, zf + v * (zb - zf)};
}

struct WatertightStats {
    int rays = 0;
    int seamRays = 0;
    int longestWalk = 0;
};

// The watertightness oracle for every element of a prescription whose solids are in
// `scene` (see the top of the file). `rays` random rays and rays / 5 seam rays per element.
void expectWatertight(const Prescription& p, const Scene& scene, int rays, uint64_t seed,
                      WatertightStats* stats = nullptr) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    std::vector<int> all;
    for (const SceneObject& o : scene.objects()) all.push_back(o.id);
    for (const LensSolid& s : lensSolids(p)) {
        const std::vector<int> own = facesOf(scene, s.name);
        ASSERT_GE(own.size(), 3u) << s.name;
        const int glass = scene.object(own.front()).mediumFront != 0
                              ? scene.object(own.front()).mediumFront
                              : scene.object(own.front()).mediumBack;
        int leaks = 0, wrongSide = 0, badWalks = 0;
        for (int i = 0; i < rays; ++i) {
            const Ray ray{randomInside(s, rng), randomDirection(rng)};
            // It leaves through one of the element's own faces, from the glass.
            const Hit h = firstHit(scene, own, ray, -1);
            if (h.object < 0) {
                if (++leaks < 5) ADD_FAILURE() << s.name << ": ray escapes: " << ray;
                continue;
            }
            const SceneObject& o = scene.object(h.object);
            if (mediumFrom(o, ray.direction, h.normal) != glass) {
                if (++wrongSide < 5) ADD_FAILURE() << s.name << ": leaves via " << o << " " << ray;
            }
            // Followed through the whole lens it sees consistent media and ends in air.
            int medium = glass, start = -1, steps = 0;
            Ray walk = ray;
            bool ok = true;
            for (; steps < 64; ++steps) {
                const Hit w = firstHit(scene, all, walk, start);
                if (w.object < 0) break;
                const SceneObject& wo = scene.object(w.object);
                if (mediumFrom(wo, walk.direction, w.normal) != medium) {
                    ok = false;
                    if (badWalks < 5) {
                        ADD_FAILURE() << s.name << ": at " << wo.name << " the ray is in medium "
                                      << medium << " but the face has " << wo;
                    }
                    break;
                }
                medium = mediumTo(wo, walk.direction, w.normal);
                walk.origin = walk.origin + w.t * walk.direction;
                start = w.object;
            }
            if (ok && medium != 0) {
                ok = false;
                if (badWalks < 5) ADD_FAILURE() << s.name << ": ray ends in medium " << medium;
            }
            badWalks += !ok;
            if (stats) stats->longestWalk = std::max(stats->longestWalk, steps);
        }
        // Rays aimed at the seams: face rim / flat, flat / edge, and the step of a cemented
        // interface (an anamorphic face's curved rim on the edge), at random azimuths.
        const double seamRadius[] = {s.front.faceRadiusMm, s.edgeRadiusMm, s.back.faceRadiusMm,
                                     s.edgeRadiusMm};
        int seamRays = 0;
        for (int i = 0; i < rays / 5; ++i) {
            const double phi = 2.0 * std::numbers::pi * uni(rng);
            const double x = seamRadius[i % 4] * std::cos(phi),
                         y = seamRadius[i % 4] * std::sin(phi);
            const Vec3 target{x, y, i % 4 < 2 ? s.frontZAt(x, y) : s.backZAt(x, y)};
            const Vec3 origin = randomInside(s, rng);
            const Ray ray{origin, glm::normalize(target - origin)};
            ++seamRays;
            // Stopped at the seam (or before it, where a meniscus curls back): a crack would
            // let it through to a face beyond, or out. Which face takes the seam point is a
            // tie, and where the glass turns a reflex corner there (face rim to flat) the ray
            // only touches the boundary, so the side it meets it from is not checked here.
            const Hit h = firstHit(scene, own, ray, -1);
            const double reach = glm::length(target - origin);
            if (h.object < 0 || h.t > reach * (1.0 + 1e-12)) {
                if (++leaks < 5) ADD_FAILURE() << s.name << ": seam ray passes: " << ray;
            }
        }
        EXPECT_EQ(leaks, 0) << s.name;
        EXPECT_EQ(wrongSide, 0) << s.name;
        EXPECT_EQ(badWalks, 0) << s.name;
        if (stats) {
            stats->rays += rays;
            stats->seamRays += seamRays;
        }
    }
}

// Every Example Lens

TEST(LensSolid, EveryExampleBuildsWatertightSolids) {
    std::vector<std::filesystem::path> files;
    for (const auto& entry :
         std::filesystem::directory_iterator(std::string(VEIL_SOURCE_DIR) + "/examples/lenses")) {
        if (entry.path().extension() == ".toml") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    ASSERT_GE(files.size(), 6u);
    for (const auto& file : files) {
        SCOPED_TRACE(file.filename().string());
        const Prescription p = readLensFile(file, GlassCatalog::builtIn());
        Scene scene;
        addLensSolids(p, scene);
        const std::vector<LensSolid> solids = lensSolids(p);
        EXPECT_EQ(solids.size(), p.elements().size());
        // Every face of every element exists and is placed as the prescription says.
        for (const LensSolid& s : solids) {
            const SceneObject& edge = get(scene, s.name + ".edge");
            EXPECT_EQ(edge.kind, ObjectKind::LensEdge);
            const auto& cyl = std::get<CylinderPatch>(std::get<FaceGeometry>(edge.geometry));
            EXPECT_EQ(cyl.radiusMm, s.edgeRadiusMm);
            // Between the rims (their enclosures, for an anamorphic face's curved rim).
            const LensSide& lower = s.direction > 0.0 ? s.front : s.back;
            const LensSide& upper = s.direction > 0.0 ? s.back : s.front;
            EXPECT_EQ(cyl.zMinMm, lower.rimZLoMm);
            EXPECT_EQ(cyl.zMaxMm, upper.rimZHiMm);
            EXPECT_EQ(cyl.rims != nullptr,
                      !isRotational(s.front.shape) || !isRotational(s.back.shape));
            for (const LensSide* side : {&s.front, &s.back}) {
                const SceneObject& face = get(scene, p.surfaces[side->surface].name);
                EXPECT_EQ(face.sequentialSurface, side->surface);
                EXPECT_EQ(face.frame.translation.z, side->vertexZMm);
                EXPECT_EQ(std::get<CircularAperture>(patchOf(face).aperture).radiusMm,
                          side->faceRadiusMm);
            }
        }
        WatertightStats stats;
        expectWatertight(p, scene, 10000, 17, &stats);
        // The scene's own closest hit (bounds culling included) agrees with the loop.
        scene.commit();
        std::vector<int> all;
        for (const SceneObject& o : scene.objects()) all.push_back(o.id);
        std::mt19937_64 rng(19);
        int agree = 0;
        for (const LensSolid& s : solids) {
            for (int i = 0; i < 1000; ++i) {
                const Ray ray{randomInside(s, rng), randomDirection(rng)};
                const Hit expect = firstHit(scene, all, ray, -1);
                const auto got = scene.closestHit(ray);
                ASSERT_EQ(got.has_value(), expect.object >= 0) << ray;
                if (!got) continue;
                EXPECT_EQ(got->object, expect.object) << ray;
                EXPECT_EQ(got->t, expect.t) << ray;
                agree += got->object == expect.object;
            }
        }
        EXPECT_EQ(agree, 1000 * static_cast<int>(solids.size()));
        std::cout << file.filename().string() << ": " << solids.size() << " elements, "
                  << scene.objects().size() << " objects, " << stats.rays << " random and "
                  << stats.seamRays << " seam rays, longest walk " << stats.longestWalk
                  << " faces\n";
    }
}

TEST(LensSolid, DoubleGaussNamesMediaAndCementedFaces) {
    const Prescription p = example("double_gauss_50mm.toml");
    Scene scene;
    addLensSolids(p, scene);
    std::vector<std::string> names;
    for (const SceneObject& o : scene.objects()) names.push_back(o.name);
    const std::vector<std::string> expected = {
        "L1.front", "L1.flat1", "L1.edge",  "L1.flat2", "L1.back",  "L2.front",
        "L2.flat1", "L2.edge",  "L2.back",  "L3.edge",  "L3.flat2", "L3.back",
        "L4.front", "L4.flat1", "L4.edge",  "L4.back",  "L5.edge",  "L5.flat2",
        "L5.back",  "L6.front", "L6.flat1", "L6.edge",  "L6.flat2", "L6.back"};
    EXPECT_EQ(names, expected);

    // Cemented faces: one object, glass on both sides, reachable by both names.
    for (const auto& [front, back, name, alias, surface] :
         {std::tuple{"L2", "L3", "L2.back", "L3.front", 4},
          std::tuple{"L4", "L5", "L4.back", "L5.front", 8}}) {
        const SceneObject& face = get(scene, name);
        EXPECT_EQ(scene.find(alias), &face);
        EXPECT_EQ(face.aliases, std::vector<std::string>{alias});
        EXPECT_EQ(face.kind, ObjectKind::LensFace);
        EXPECT_EQ(face.part, front);
        EXPECT_EQ(face.sequentialSurface, surface);
        // Light runs toward +z: the element behind is on the +z (front) side of the face.
        EXPECT_EQ(scene.media()[face.mediumBack].material, p.surfaces[surface - 1].material);
        EXPECT_EQ(scene.media()[face.mediumFront].material, p.surfaces[surface].material);
        EXPECT_NE(face.mediumFront, 0);
        EXPECT_NE(face.mediumBack, 0);
        EXPECT_NE(face.mediumFront, face.mediumBack);
        // Glass touches glass out to the smaller element: both are 12.9 mm (L2/L3) and
        // 11.2 mm (L4/L5) here, so no step.
        const double rc = std::min(lensSolids(p)[front[1] - '1'].edgeRadiusMm,
                                   lensSolids(p)[back[1] - '1'].edgeRadiusMm);
        EXPECT_EQ(std::get<CircularAperture>(patchOf(face).aperture).radiusMm, rc);
        EXPECT_EQ(scene.find(std::string(front) + ".flat2"), nullptr);
        EXPECT_EQ(scene.find(std::string(back) + ".flat1"), nullptr);
    }
    EXPECT_EQ(std::get<CircularAperture>(patchOf(get(scene, "L2.back")).aperture).radiusMm, 12.9);

    // Six glasses (L1 and L2 share theirs) plus air.
    EXPECT_EQ(scene.media().size(), 6u);
    EXPECT_EQ(get(scene, "L1.front").mediumFront, get(scene, "L2.front").mediumFront);
    // The stop gets no object here (the mechanics builder makes the plate).
    EXPECT_EQ(scene.find("stop"), nullptr);
    // Sizes: L3's edge radius is the largest mechanical sd of its surfaces (12.9 at the
    // cemented face, 10.4 at its back), and its back gets the wider flat.
    const auto& flat = std::get<AnnularAperture>(patchOf(get(scene, "L3.flat2")).aperture);
    EXPECT_EQ(flat.innerRadiusMm, 9.1);
    EXPECT_EQ(flat.outerRadiusMm, 12.9);
}

TEST(LensSolid, SingletFacesMediaAndProperties) {
    Prescription p = example("singlet.toml");
    p.surfaces[3].coating = "ar_v";
    Scene scene;
    addLensSolids(p, scene);
    ASSERT_EQ(scene.objects().size(), 5u);
    const int glass = get(scene, "L1.edge").mediumBack;
    EXPECT_EQ(scene.media()[glass].name, "N-BK7");
    EXPECT_EQ(scene.media()[glass].material, Material::catalog("N-BK7"));

    // Front face: vertex at z = 0 (surface 1 is the stop at z = 0, so the lens is at 1.0),
    // glass on its +z side.
    const SceneObject& front = get(scene, "L1.front");
    EXPECT_EQ(front.kind, ObjectKind::LensFace);
    EXPECT_EQ(front.part, "L1");
    EXPECT_EQ(front.frame.translation, Vec3(0.0, 0.0, 1.0));
    EXPECT_EQ(front.mediumFront, glass);
    EXPECT_EQ(front.mediumBack, 0);
    EXPECT_EQ(front.property, "");
    const auto& shape = std::get<SphereShape>(patchOf(front).shape);
    EXPECT_DOUBLE_EQ(shape.curvature, 1.0 / 59.26);

    const SceneObject& back = get(scene, "L1.back");
    EXPECT_EQ(back.frame.translation, Vec3(0.0, 0.0, 5.0));
    EXPECT_EQ(back.mediumFront, 0);
    EXPECT_EQ(back.mediumBack, glass);
    EXPECT_EQ(back.property, "ar_v");

    // Flats: glass toward the other side, at the rim height of their face.
    const SceneObject& flat1 = get(scene, "L1.flat1");
    EXPECT_EQ(flat1.kind, ObjectKind::LensFlat);
    EXPECT_EQ(flat1.property, "lens_flat");
    EXPECT_EQ(flat1.mediumFront, glass);
    EXPECT_EQ(flat1.sequentialSurface, -1);
    EXPECT_DOUBLE_EQ(flat1.frame.translation.z, 1.0 + sag(SphereShape{1.0 / 59.26}, 10.5 * 10.5));
    const SceneObject& flat2 = get(scene, "L1.flat2");
    EXPECT_EQ(flat2.mediumBack, glass);
    EXPECT_EQ(flat2.mediumFront, 0);
    const auto& ring = std::get<AnnularAperture>(patchOf(flat2).aperture);
    EXPECT_EQ(ring.innerRadiusMm, 10.5);
    EXPECT_EQ(ring.outerRadiusMm, 12.0);

    // Edge: outward normal, air outside, spanning the flats exactly.
    const SceneObject& edge = get(scene, "L1.edge");
    EXPECT_EQ(edge.property, "lens_edge");
    EXPECT_EQ(edge.mediumFront, 0);
    const auto& cyl = std::get<CylinderPatch>(std::get<FaceGeometry>(edge.geometry));
    EXPECT_TRUE(cyl.outward);
    EXPECT_EQ(cyl.zMinMm, flat1.frame.translation.z);
    EXPECT_EQ(cyl.zMaxMm, flat2.frame.translation.z);
    // The edge is as long as the lens is thick at the clear radius, where the flats sit:
    // 4 mm at the centre less the two sags at 10.5 mm (R1 = 59.26, R2 = -394.56).
    const double sag1 = 59.26 - std::sqrt(59.26 * 59.26 - 10.5 * 10.5);
    const double sag2 = 394.56 - std::sqrt(394.56 * 394.56 - 10.5 * 10.5);
    EXPECT_NEAR(cyl.zMaxMm - cyl.zMinMm, 4.0 - sag1 - sag2, 1e-12);

    // Options override the properties.
    Scene custom;
    LensSolidOptions options;
    options.edgeProperty = "ground";
    options.flatProperty = "black_paint";
    options.opticalFaceProperty = "uncoated";
    addLensSolids(p, custom, options);
    EXPECT_EQ(get(custom, "L1.edge").property, "ground");
    EXPECT_EQ(get(custom, "L1.flat1").property, "black_paint");
    EXPECT_EQ(get(custom, "L1.back").property, "uncoated");
}

TEST(LensSolid, CatadioptricMirrorsAreThinFaces) {
    const Prescription p = example("catadioptric_2000mm.toml");
    Scene scene;
    addLensSolids(p, scene);
    for (const auto& [name, surface] : {std::pair{"M1", 4}, std::pair{"M2", 5}}) {
        const SceneObject& m = get(scene, name);
        EXPECT_EQ(m.kind, ObjectKind::MirrorFace);
        EXPECT_EQ(m.part, name);
        EXPECT_EQ(m.mediumFront, 0);
        EXPECT_EQ(m.mediumBack, 0);
        EXPECT_EQ(m.sequentialSurface, surface);
    }
    // The primary has a central hole that passes the light from M2 to the field lens.
    const auto& ring = std::get<AnnularAperture>(patchOf(get(scene, "M1")).aperture);
    EXPECT_EQ(ring.innerRadiusMm, p.surfaces[4].innerSemiDiameterMm);
    EXPECT_EQ(ring.innerRadiusMm, 29.2);
    EXPECT_EQ(ring.outerRadiusMm, p.surfaces[4].clearSemiDiameterMm);
    EXPECT_EQ(std::get<CircularAperture>(patchOf(get(scene, "M2")).aperture).radiusMm,
              p.surfaces[5].clearSemiDiameterMm);
    // z: aperture ring at 0, L1 at 25..41, M1 at 460.14, M2 back at 61.0, L2 at 470.14.
    EXPECT_NEAR(get(scene, "M1").frame.translation.z, 460.14, 1e-9);
    EXPECT_NEAR(get(scene, "M2").frame.translation.z, 61.0, 1e-9);
    EXPECT_NEAR(get(scene, "L2.front").frame.translation.z, 470.14, 1e-9);
    // Objects in prescription order: L1's faces, the mirrors, then L2's.
    EXPECT_EQ(scene.objects()[5].name, "M1");
    EXPECT_EQ(scene.objects()[6].name, "M2");
}

// Errors

TEST(LensSolid, ThinLensIsANegativeEdgeThicknessError) {
    Prescription p = test::equiconvexSinglet(50.0, 1.0, 10.0, 12.0);
    // Both rims are sag(10) = 50 - sqrt(2400) from their vertices, toward each other.
    const double rim = 50.0 - std::sqrt(2400.0);
    std::ostringstream expect;
    expect << "L1: negative edge thickness " << (1.0 - 2.0 * rim) << " mm at r = 12 mm";
    Scene scene;
    try {
        addLensSolids(p, scene);
        FAIL() << "no error";
    } catch (const ModelError& e) {
        EXPECT_EQ(std::string(e.what()), expect.str());
        EXPECT_EQ(e.object(), "L1");
    }
    EXPECT_TRUE(scene.objects().empty());  // nothing half-built
    EXPECT_THROW(lensSolids(p), ModelError);

    // Thick enough, it builds.
    p.surfaces[1].thicknessMm = 2.1;
    EXPECT_NO_THROW(lensSolids(p));
}

TEST(LensSolid, FacesCrossingInsideTheApertureAreAnError) {
    // A flat front and a W-shaped aspheric back (z = 1 - 0.06 r^2 + 6e-4 r^4) that dips below
    // the front between r ~ 4.3 and 7.2 mm, while the edge itself is 1 mm thick.
    Prescription p = test::startLens(kInf, 10.0);
    Surface s1 = test::surface(0.0, 1.0, Material::model(1.5, 60.0));
    s1.clearSemiDiameterMm = 10.0;
    s1.mechSemiDiameterMm = 11.0;
    Surface s2 = test::surface(0.0, 50.0);
    s2.asphere[0] = -0.06;
    s2.asphere[1] = 6e-4;
    s2.clearSemiDiameterMm = 10.0;
    s2.mechSemiDiameterMm = 11.0;
    p.surfaces.push_back(s1);
    p.surfaces.push_back(s2);
    test::finishLens(p);
    try {
        lensSolids(p);
        FAIL() << "no error";
    } catch (const ModelError& e) {
        const std::string what = e.what();
        EXPECT_EQ(what.rfind("L1: front and back faces cross: thickness -", 0), 0u) << what;
        // The thinnest point is at r^2 = 0.06 / (2 * 6e-4) = 50, thickness 1 - 1.5 = -0.5
        // (found on a grid of radii: within 1e-5 mm of it).
        EXPECT_NE(what.find("thickness -0.49999"), std::string::npos) << what;
        EXPECT_NE(what.find("mm at r = 7.0"), std::string::npos) << what;
    }
}

TEST(LensSolid, MissingClearSemiDiameterNamesTheSurface) {
    Prescription p = example("singlet.toml");
    p.surfaces[3].clearSemiDiameterMm = 0.0;
    p.surfaces[3].mechSemiDiameterMm = 0.0;
    Scene scene;
    try {
        addLensSolids(p, scene);
        FAIL() << "no error";
    } catch (const ModelError& e) {
        EXPECT_EQ(e.object(), "L1.back");
    }
}

TEST(LensSolid, OverlappingNeighboursAreAnError) {
    Prescription p = test::startLens(kInf, 10.0);
    auto add = [&](double r, double t, Material m) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = 10.0;
        p.surfaces.push_back(s);
    };
    add(50.0, 5.0, Material::model(1.5, 60.0));
    add(-50.0, 0.1, Material::air());             // L1's back bulges 1.01 mm toward L2 at r = 10
    add(-30.0, 5.0, Material::model(1.6, 40.0));  // L2's front curls back 1.72 mm
    add(0.0, 50.0, Material::air());
    test::finishLens(p);
    try {
        lensSolids(p);
        FAIL() << "no error";
    } catch (const ModelError& e) {
        const std::string what = e.what();
        EXPECT_EQ(what.rfind("L1: overlaps L2: air gap -0.6", 0), 0u) << what;
        EXPECT_NE(what.find("at r = 10 mm"), std::string::npos) << what;
    }
}

// Cemented Steps

// A doublet whose elements have different radii: the larger one's part of the interface
// beyond the smaller one is a flat step.
Prescription steppedDoublet(double radiusA, double radiusB) {
    Prescription p = test::startLens(kInf, 16.0);
    auto add = [&](double r, double t, Material m, double clear, double mech) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = clear;
        s.mechSemiDiameterMm = mech;
        p.surfaces.push_back(s);
    };
    add(60.0, 6.0, Material::model(1.5168, 64.2), 9.0, radiusA);
    add(-40.0, 2.5, Material::model(1.62, 36.4), 9.0, std::min(radiusA, radiusB));
    add(-150.0, 90.0, Material::air(), 9.0, radiusB);
    test::finishLens(p);
    return p;
}

TEST(LensSolid, CementedElementsOfDifferentSizeGetAStep) {
    for (const bool frontLarger : {true, false}) {
        SCOPED_TRACE(frontLarger ? "front element larger" : "back element larger");
        const double ra = frontLarger ? 12.0 : 10.0, rb = frontLarger ? 10.0 : 12.0;
        const Prescription p = steppedDoublet(ra, rb);
        Scene scene;
        addLensSolids(p, scene);
        const std::vector<LensSolid> solids = lensSolids(p);
        ASSERT_EQ(solids.size(), 2u);
        EXPECT_EQ(solids[0].edgeRadiusMm, ra);
        EXPECT_EQ(solids[1].edgeRadiusMm, rb);
        // The shared face reaches the smaller radius.
        const SceneObject& shared = get(scene, "L1.back");
        EXPECT_EQ(scene.find("L2.front"), &shared);
        EXPECT_EQ(std::get<CircularAperture>(patchOf(shared).aperture).radiusMm, 10.0);
        // The step: the larger element's flat on the cemented side, at the shared rim.
        const std::string step = frontLarger ? "L1.flat2" : "L2.flat1";
        const std::string none = frontLarger ? "L2.flat1" : "L1.flat2";
        const SceneObject& flat = get(scene, step);
        EXPECT_EQ(scene.find(none), nullptr);
        const auto& ring = std::get<AnnularAperture>(patchOf(flat).aperture);
        EXPECT_EQ(ring.innerRadiusMm, 10.0);
        EXPECT_EQ(ring.outerRadiusMm, 12.0);
        EXPECT_EQ(flat.frame.translation.z, solids[0].back.rimZMm);
        EXPECT_EQ(solids[0].back.rimZMm, solids[1].front.rimZMm);
        // Air on one side, the larger element's glass on the other.
        const int glassLarge = get(scene, frontLarger ? "L1.edge" : "L2.edge").mediumBack;
        EXPECT_EQ(flat.mediumFront + flat.mediumBack, glassLarge);
        EXPECT_EQ(frontLarger ? flat.mediumBack : flat.mediumFront, glassLarge);
        // Each edge runs from its other side to the step.
        const auto& edgeA =
            std::get<CylinderPatch>(std::get<FaceGeometry>(get(scene, "L1.edge").geometry));
        const auto& edgeB =
            std::get<CylinderPatch>(std::get<FaceGeometry>(get(scene, "L2.edge").geometry));
        EXPECT_EQ(edgeA.zMaxMm, flat.frame.translation.z);
        EXPECT_EQ(edgeB.zMinMm, flat.frame.translation.z);
        expectWatertight(p, scene, 10000, 23);
    }
}

// Anamorphic Faces

// A cemented doublet of a biconic, a toroidal interface and a cylinder back, with a clear
// aperture smaller than the mechanical one: every anamorphic face runs out to the edge (no
// flats), and the edges end on the curved rims. Watertight like every other solid.
Prescription anamorphicDoublet(double radiusA, double radiusB) {
    Prescription p = test::startLens(kInf, 12.0);
    auto add = [&](double r, double t, Material m, double mech, std::optional<Anamorphic> a) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = 7.0;
        s.mechSemiDiameterMm = mech;
        s.anamorphic = a;
        p.surfaces.push_back(s);
    };
    add(45.0, 6.0, Material::model(1.5168, 64.2), radiusA,
        Anamorphic{Anamorphic::Kind::Biconic, 1.0 / 30.0, -0.5});
    add(-35.0, 2.5, Material::model(1.62, 36.4), std::min(radiusA, radiusB),
        Anamorphic{Anamorphic::Kind::Toroidal, -1.0 / 60.0, 0.0});
    add(kInf, 60.0, Material::air(), radiusB,
        Anamorphic{Anamorphic::Kind::Toroidal, 1.0 / 90.0, 0.0});
    test::finishLens(p);
    return p;
}

TEST(LensSolid, AnamorphicFacesRunToTheEdge) {
    const Prescription p = anamorphicDoublet(9.0, 9.0);
    Scene scene;
    addLensSolids(p, scene);
    const std::vector<LensSolid> solids = lensSolids(p);
    ASSERT_EQ(solids.size(), 2u);
    for (const char* face : {"L1.front", "L1.back", "L2.back"})
        EXPECT_EQ(std::get<CircularAperture>(patchOf(get(scene, face)).aperture).radiusMm, 9.0)
            << face;
    for (const char* flat : {"L1.flat1", "L1.flat2", "L2.flat1", "L2.flat2"})
        EXPECT_EQ(scene.find(flat), nullptr) << flat;
    for (const LensSolid& s : solids) {
        const auto& edge =
            std::get<CylinderPatch>(std::get<FaceGeometry>(get(scene, s.name + ".edge").geometry));
        ASSERT_TRUE(edge.rims);
        EXPECT_TRUE(edge.rims->lower && edge.rims->upper);
        EXPECT_TRUE(std::isnan(s.front.rimZMm));
        EXPECT_LT(s.front.rimZLoMm, s.front.rimZHiMm);  // the rim is a curve
    }
    EXPECT_THROW(solids[0].frontZ(1.0), std::logic_error);
    expectWatertight(p, scene, 10000, 29);
}

TEST(LensSolid, CementedAnamorphicFaceOfDifferentRadiiIsAnError) {
    try {
        lensSolids(anamorphicDoublet(10.0, 9.0));
        FAIL() << "no error";
    } catch (const ModelError& e) {
        EXPECT_EQ(e.object(), "L1.back");
        EXPECT_NE(std::string(e.what()).find("step that is not a plane"), std::string::npos)
            << e.what();
    }
}

TEST(LensSolid, CementedTripletWithASmallMiddleElement) {
    // Radii 12 / 10 / 11: the middle element is the smaller partner at both interfaces, so
    // the outer ones get steps (L1.flat2 from 10 to 12, L3.flat1 from 10 to 11) and the
    // middle one has no flat at all.
    Prescription p = test::startLens(kInf, 16.0);
    auto add = [&](double r, double t, Material m, double mech) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = 9.0;
        s.mechSemiDiameterMm = mech;
        p.surfaces.push_back(s);
    };
    add(60.0, 6.0, Material::model(1.5168, 64.2), 12.0);
    add(-40.0, 2.5, Material::model(1.62, 36.4), 10.0);
    add(40.0, 5.0, Material::model(1.5168, 64.2), 10.0);
    add(-150.0, 90.0, Material::air(), 11.0);
    test::finishLens(p);
    Scene scene;
    addLensSolids(p, scene);
    std::vector<std::string> names;
    for (const SceneObject& o : scene.objects()) names.push_back(o.name);
    EXPECT_EQ(names, (std::vector<std::string>{"L1.front", "L1.flat1", "L1.edge", "L1.flat2",
                                               "L1.back", "L2.edge", "L2.back", "L3.flat1",
                                               "L3.edge", "L3.flat2", "L3.back"}));
    EXPECT_EQ(scene.find("L2.front"), scene.find("L1.back"));
    EXPECT_EQ(scene.find("L3.front"), scene.find("L2.back"));
    // Two media for three glasses: L1 and L3 are the same model glass.
    EXPECT_EQ(scene.media().size(), 3u);
    const auto& step = std::get<AnnularAperture>(patchOf(get(scene, "L3.flat1")).aperture);
    EXPECT_EQ(step.innerRadiusMm, 10.0);
    EXPECT_EQ(step.outerRadiusMm, 11.0);
    expectWatertight(p, scene, 10000, 41);
}

// Mirrors

TEST(LensSolid, ManginMirrorIsTheSilveredBackOfOneElement) {
    // Light enters L1 (N-BK7), reflects at its silvered back and leaves through the front
    // again (surface 3 is the front surface on the way back).
    Prescription p = test::startLens(kInf, 30.0);
    auto add = [&](double r, double t, Material m, bool mirror) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = 20.0;
        s.mechSemiDiameterMm = 22.0;
        s.mirror = mirror;
        p.surfaces.push_back(s);
    };
    const Material glass = Material::catalog("N-BK7");
    add(-200.0, 8.0, glass, false);
    add(-300.0, -8.0, glass, true);
    add(-200.0, -100.0, Material::air(), false);
    test::finishLens(p);
    ASSERT_EQ(p.surfaces[3].name, "S3");

    Scene scene;
    addLensSolids(p, scene);
    EXPECT_EQ(scene.objects().size(), 5u);
    const SceneObject& front = get(scene, "L1.front");
    EXPECT_EQ(scene.find("S3"), &front);  // the exit surface is the front face again
    const SceneObject& back = get(scene, "L1.back");
    EXPECT_EQ(back.kind, ObjectKind::MirrorFace);
    EXPECT_EQ(back.part, "L1");
    EXPECT_EQ(back.sequentialSurface, 2);
    EXPECT_EQ(back.mediumFront, 0);  // air behind the silvering (+z)
    EXPECT_EQ(scene.media()[back.mediumBack].material, glass);
    expectWatertight(p, scene, 10000, 29);
}

TEST(LensSolid, RepeatedPassThroughADoubletAddsNoSecondCopy) {
    // A Mangin doublet: through L1 and L2, off L2's silvered back, back through L2 and L1.
    // The return through L1 (surfaces 4 and 5) is the same glass between the same faces.
    Prescription p = test::startLens(kInf, 30.0);
    auto add = [&](double r, double t, Material m, bool mirror) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = 20.0;
        s.mechSemiDiameterMm = 22.0;
        s.mirror = mirror;
        p.surfaces.push_back(s);
    };
    const Material crown = Material::model(1.5168, 64.2), flint = Material::model(1.62, 36.4);
    add(-200.0, 5.0, crown, false);
    add(-250.0, 6.0, flint, false);
    add(-300.0, -6.0, flint, true);
    add(-250.0, -5.0, crown, false);
    add(-200.0, -100.0, Material::air(), false);
    test::finishLens(p);
    ASSERT_EQ(p.elements().size(), 3u);  // L3 is the return pass through L1's glass
    EXPECT_EQ(lensSolids(p).size(), 2u);
    Scene scene;
    addLensSolids(p, scene);
    EXPECT_EQ(scene.find("L3.front"), scene.find("L1.back"));
    EXPECT_EQ(scene.find("L3.back"), scene.find("L1.front"));
    EXPECT_EQ(get(scene, "L2.back").kind, ObjectKind::MirrorFace);
    EXPECT_EQ(get(scene, "L1.back").aliases, (std::vector<std::string>{"L2.front", "L3.front"}));
    expectWatertight(p, scene, 5000, 43);
}

TEST(LensSolid, SpotSecondaryIsCutOutOfTheCorrector) {
    // Gregory-Maksutov: meniscus corrector, primary M1, and the secondary M2 aluminised on
    // the corrector's back surface (same vertex, same shape).
    Prescription p = test::startLens(kInf, 90.0);
    auto add = [&](double r, double t, Material m, double sd, double mech, bool mirror) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = sd;
        s.mechSemiDiameterMm = mech;
        s.mirror = mirror;
        p.surfaces.push_back(s);
    };
    const Material glass = Material::catalog("N-BK7");
    add(-150.0, 10.0, glass, 50.0, 52.0, false);
    add(-155.0, 300.0, Material::air(), 50.0, 52.0, false);
    add(-800.0, -300.0, Material::air(), 55.0, 0.0, true);
    add(-155.0, 350.0, Material::air(), 15.0, 0.0, true);
    test::finishLens(p);
    ASSERT_EQ(p.surfaces[4].name, "M2");

    Scene scene;
    addLensSolids(p, scene);
    const SceneObject& back = get(scene, "L1.back");
    const SceneObject& spot = get(scene, "M2");
    EXPECT_EQ(spot.kind, ObjectKind::MirrorFace);
    EXPECT_EQ(spot.part, "L1");
    EXPECT_EQ(spot.sequentialSurface, 4);
    EXPECT_EQ(spot.frame.translation, back.frame.translation);
    EXPECT_EQ(spot.mediumFront, back.mediumFront);
    EXPECT_EQ(spot.mediumBack, back.mediumBack);
    EXPECT_EQ(std::get<CircularAperture>(patchOf(spot).aperture).radiusMm, 15.0);
    const auto& ring = std::get<AnnularAperture>(patchOf(back).aperture);
    EXPECT_EQ(ring.innerRadiusMm, 15.0);
    EXPECT_EQ(ring.outerRadiusMm, 50.0);
    EXPECT_EQ(get(scene, "M1").part, "M1");
    expectWatertight(p, scene, 10000, 31);
}

// A Cassegrain-type primary with a central hole: a paraboloid (R = -400 mm, focus at
// z = -200 mm) with clear radii 12..50 mm. In the committed scene a ray parallel to the axis
// through the hole meets nothing; one on the annulus meets the mirror on the paraboloid, and
// reflected about the hit normal it runs through the focus.
TEST(LensSolid, MirrorWithAHoleIsAnAnnulus) {
    Prescription p = test::startLens(kInf, 100.0);
    Surface m1 = test::surface(-400.0, -150.0);
    m1.conic = -1.0;
    m1.mirror = true;
    m1.clearSemiDiameterMm = 50.0;
    m1.mechSemiDiameterMm = 52.0;
    m1.innerSemiDiameterMm = 12.0;
    p.surfaces.push_back(m1);
    test::finishLens(p);

    Scene scene;
    addLensSolids(p, scene);
    ASSERT_EQ(scene.objects().size(), 1u);
    const SceneObject& mirror = get(scene, "M1");
    EXPECT_EQ(mirror.kind, ObjectKind::MirrorFace);
    const auto& ring = std::get<AnnularAperture>(patchOf(mirror).aperture);
    EXPECT_EQ(ring.innerRadiusMm, 12.0);
    EXPECT_EQ(ring.outerRadiusMm, 50.0);
    scene.commit();

    for (double h : {0.0, 5.0, 11.99}) {
        const Ray through{Vec3(h, 0.0, -100.0), Vec3(0.0, 0.0, 1.0)};
        const auto hit = scene.closestHit(through);
        EXPECT_FALSE(hit.has_value()) << "h = " << h << ": " << *hit;
    }
    for (double h : {12.01, 30.0, 49.9}) {
        const Ray onRing{Vec3(0.0, h, -100.0), Vec3(0.0, 0.0, 1.0)};
        const auto hit = scene.closestHit(onRing);
        ASSERT_TRUE(hit.has_value()) << "h = " << h;
        EXPECT_EQ(hit->object, mirror.id);
        EXPECT_NEAR(hit->point.z, -h * h / 800.0, 1e-12);  // the paraboloid's sag
        const Vec3 d =
            onRing.direction - 2.0 * glm::dot(onRing.direction, hit->normal) * hit->normal;
        ASSERT_LT(d.z, 0.0);
        const Vec3 atFocusPlane = hit->point + d * ((-200.0 - hit->point.z) / d.z);
        EXPECT_NEAR(atFocusPlane.y, 0.0, 1e-9) << "h = " << h;
        EXPECT_NEAR(atFocusPlane.x, 0.0, 1e-12);
    }
    // Beyond the outer edge: nothing either.
    EXPECT_FALSE(scene.closestHit({Vec3(0.0, 50.1, -100.0), Vec3(0.0, 0.0, 1.0)}).has_value());
}

// A hole through glass would need a bore: a lens element with a hole is a model error.
TEST(LensSolid, HoleInALensElementIsAnError) {
    Prescription p = test::startLens(kInf, 20.0);
    Surface s1 = test::surface(50.0, 5.0, Material::model(1.5, 60.0));
    s1.clearSemiDiameterMm = 10.0;
    s1.innerSemiDiameterMm = 2.0;
    Surface s2 = test::surface(-50.0, 50.0);
    s2.clearSemiDiameterMm = 10.0;
    p.surfaces.push_back(s1);
    p.surfaces.push_back(s2);
    test::finishLens(p);
    Scene scene;
    try {
        addLensSolids(p, scene);
        FAIL() << "no error";
    } catch (const ModelError& e) {
        EXPECT_EQ(e.object(), "L1.front");
        EXPECT_NE(std::string(e.what()).find("holes in lens elements are not modelled"),
                  std::string::npos)
            << e.what();
    }
}

TEST(LensSolid, ElementAfterAMirrorRunsTowardMinusZ) {
    Prescription p = test::startLens(kInf, 60.0);
    auto add = [&](double r, double t, Material m, double sd, double mech, bool mirror) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = sd;
        s.mechSemiDiameterMm = mech;
        s.mirror = mirror;
        p.surfaces.push_back(s);
    };
    add(-400.0, -100.0, Material::air(), 40.0, 0.0, true);
    add(-80.0, -6.0, Material::model(1.5168, 64.2), 20.0, 22.0, false);
    add(100.0, -50.0, Material::air(), 20.0, 22.0, false);
    test::finishLens(p);
    Scene scene;
    addLensSolids(p, scene);
    const std::vector<LensSolid> solids = lensSolids(p);
    ASSERT_EQ(solids.size(), 1u);
    EXPECT_EQ(solids[0].direction, -1.0);
    const SceneObject& front = get(scene, "L1.front");
    const SceneObject& back = get(scene, "L1.back");
    EXPECT_EQ(front.frame.translation.z, -100.0);
    EXPECT_EQ(back.frame.translation.z, -106.0);
    // The glass lies at -z of the front face and at +z of the back face.
    EXPECT_EQ(front.mediumFront, 0);
    EXPECT_NE(front.mediumBack, 0);
    EXPECT_EQ(back.mediumFront, front.mediumBack);
    EXPECT_EQ(back.mediumBack, 0);
    expectWatertight(p, scene, 10000, 37);
}

TEST(LensSolid, PrintsItself) {
    const std::vector<LensSolid> solids = lensSolids(example("singlet.toml"));
    std::ostringstream os;
    os << solids[0] << " " << LensSolidOptions{};
    EXPECT_EQ(
        os.str().rfind("LensSolid{L1 N-BK7, R 12 mm, direction 1, front LensSide{surface 2", 0), 0u)
        << os.str();
    EXPECT_NE(os.str().find("LensSolidOptions{edge 'lens_edge', flat 'lens_flat'"),
              std::string::npos);
}

// The glass of a lens is sealed (closestHit() in it searches the exact faces alone) only when
// commit() proves no triangle comes near the body. A ring around the singlet's butt end, 1 um
// outside it, keeps it sealed; the same ring reaching 10 um into the glass unseals it, names
// it, and a ray in the glass then meets the ring, as the brute force says; a mesh with glass
// on one side unseals that glass too.
TEST(LensSolid, GlassIsSealedOnlyWhenNoPartComesNearIt) {
    const Prescription p = example("singlet.toml");
    struct Built {
        Scene scene;
        int glass = 0;
    };
    auto build = [&](double innerGapMm, int ringMedium) {
        Built b;
        addLensSolids(p, b.scene);
        const SceneObject& edge = get(b.scene, "L1.edge");
        b.glass = edge.mediumBack;
        const auto& cyl = std::get<CylinderPatch>(std::get<FaceGeometry>(edge.geometry));
        const double rIn = cyl.radiusMm + innerGapMm;
        const double zMid = 0.5 * (cyl.zMinMm + cyl.zMaxMm);
        // 2000 segments: the inscribed polygon stays within 2e-5 mm of the circle.
        const std::vector<Vec2> profile{
            {rIn, zMid - 0.2}, {rIn + 2.0, zMid - 0.2}, {rIn + 2.0, zMid + 0.2}, {rIn, zMid + 0.2}};
        SceneObject ring;
        ring.name = "ring";
        ring.kind = ObjectKind::Mechanics;
        ring.part = "ring";
        ring.mediumFront = ringMedium < 0 ? b.glass : 0;
        ring.geometry = MeshRef{b.scene.addMesh(revolveProfile(profile, 2000).mesh)};
        b.scene.addObject(ring);
        b.scene.commit();
        return b;
    };
    auto edgeRay = [](const Scene& scene) {
        const auto& cyl =
            std::get<CylinderPatch>(std::get<FaceGeometry>(get(scene, "L1.edge").geometry));
        return Ray{Vec3(0.0, 0.0, 0.5 * (cyl.zMinMm + cyl.zMaxMm)), Vec3(1.0, 0.0, 0.0)};
    };

    const Built clear = build(1e-3, 0);
    EXPECT_TRUE(clear.scene.bodiesNotClear().empty());
    EXPECT_TRUE(clear.scene.sealed(clear.glass));
    EXPECT_FALSE(clear.scene.sealed(0));  // air never is
    const Ray r1 = edgeRay(clear.scene);
    const auto h1 = clear.scene.closestHit(r1, kInf, -1, -1, clear.glass);
    ASSERT_TRUE(h1.has_value());
    EXPECT_EQ(clear.scene.object(h1->object).name, "L1.edge");
    EXPECT_EQ(h1->t, clear.scene.closestHitBruteForce(r1)->t);

    const Built into = build(-1e-2, 0);
    ASSERT_EQ(into.scene.bodiesNotClear().size(), 1u);
    EXPECT_EQ(into.scene.bodiesNotClear()[0], "L1: ring");
    EXPECT_FALSE(into.scene.sealed(into.glass));
    const Ray r2 = edgeRay(into.scene);
    const auto h2 = into.scene.closestHit(r2, kInf, -1, -1, into.glass);
    ASSERT_TRUE(h2.has_value());
    EXPECT_EQ(into.scene.object(h2->object).name, "ring");
    EXPECT_NEAR(h2->t, into.scene.closestHitBruteForce(r2)->t, 1e-9);

    const Built glassy = build(1e-3, -1);
    EXPECT_TRUE(glassy.scene.bodiesNotClear().empty());
    EXPECT_FALSE(glassy.scene.sealed(glassy.glass));
}

}  // namespace
}  // namespace veil
