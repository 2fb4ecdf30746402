// The assembled scene of every example lens with mechanics: closest hit against a brute-force
// loop over every exact face and every triangle, for rays aimed at faces, seams and vertices,
// random rays, and rays that start on the surface they just hit (the nonsequential tracer's
// case).

#include "geometry/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <map>
#include <random>
#include <sstream>

#include "lensdata/glass_catalog.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {
namespace {

// An example: "scenes/x" as written (with its own [mechanics]), "lenses/x" with the default
// mechanics at a coarser tessellation (the brute-force oracle is slow on fine meshes).
SceneGeometry exampleScene(const std::string& name) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    SceneSpec f = readSceneFile(VEIL_SOURCE_DIR "/examples/" + name + ".toml", catalog);
    // A system a coordinate break takes off the axis, or with anamorphic surfaces, gets no
    // generated mounts (its meshes are its own [[mesh]] parts).
    if (!f.mechanics && f.model->coaxial() && f.prescription.firstAnamorphic() < 0) {
        MechanicsSpec spec;
        spec.chordToleranceMm = 0.05;
        f.mechanics = spec;
    }
    return buildSceneGeometry(f, catalog);
}

struct Mismatch {
    int count = 0;
    std::string first;
    std::map<int, int> hitsOnObject;  // by the oracle: where the rays went
    // hitOnFace() against closestHit() where that meets an exact face, and against
    // intersectFace() on every exact face whatever lies before it.
    int faceCount = 0, faceHits = 0, faceBeyond = 0;
    std::string faceFirst;
};

// One exact face alone (Scene::hitOnFace): where closestHit() meets an exact face first, the
// same hit (to 1e-12 of the distance: a face without a closed form, such as a toroid, is
// solved by a root search whose steps depend on the interval searched, and closestHit()
// searches up to the nearest hit so far); on every exact face, the general intersectFace() of
// that face alone, to the same tolerance.
void compareFaces(const Scene& scene, const Ray& ray, int startObject,
                  const std::optional<SceneHit>& fast, Mismatch& m) {
    auto note = [&](const std::string& what) {
        if (m.faceCount++ == 0) {
            std::ostringstream os;
            os << ray << " from object " << startObject << ": " << what;
            m.faceFirst = os.str();
        }
    };
    if (fast && std::holds_alternative<FaceGeometry>(scene.object(fast->object).geometry)) {
        const auto alone = scene.hitOnFace(ray, fast->object, startObject);
        const double tol = 1e-12 * std::max(1.0, fast->t);
        if (!alone || std::abs(alone->t - fast->t) > tol ||
            glm::length(alone->point - fast->point) > tol ||
            glm::length(alone->normal - fast->normal) > 1e-9 || alone->fromFront != fast->fromFront)
            note("hitOnFace differs from closestHit on " + scene.object(fast->object).name);
        ++m.faceHits;
    }
    for (const SceneObject& o : scene.objects()) {
        const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry);
        if (!f) continue;
        const auto want =
            intersectFace(*f, o.frame.toLocal(ray), 0.0, kInfinity, o.id == startObject);
        const auto got = scene.hitOnFace(ray, o.id, startObject);
        if (want.has_value() != got.has_value()) {
            note("hitOnFace and intersectFace disagree on a hit of " + o.name);
            continue;
        }
        if (!want) continue;
        if (!fast || fast->object != o.id) ++m.faceBeyond;
        const Vec3 n = o.frame.toGlobalDirection(want->normal);
        if (std::abs(got->t - want->t) > 1e-12 * std::max(1.0, want->t) ||
            glm::length(got->normal - n) > 1e-9)
            note("hitOnFace and intersectFace disagree on " + o.name);
    }
}

// `medium`: the medium the ray travels in, as the tracer passes it (-1 unknown); in a sealed
// medium closestHit() searches the exact faces alone.
void compare(const Scene& scene, const Ray& ray, int startObject, int startPrimitive, Mismatch& m,
             std::optional<SceneHit>* hitOut, int medium = -1) {
    const auto fast = scene.closestHit(ray, kInfinity, startObject, startPrimitive, medium);
    const auto slow = scene.closestHitBruteForce(ray, kInfinity, startObject, startPrimitive);
    compareFaces(scene, ray, startObject, fast, m);
    if (slow) ++m.hitsOnObject[slow->object];
    if (hitOut) *hitOut = slow;
    bool same = fast.has_value() == slow.has_value();
    if (same && fast) {
        const double tol = 1e-9 * std::max(1.0, slow->t);
        // Equal distance; the object may differ only where two faces meet at that point
        // (a tie), and then the media must still agree.
        same = std::abs(fast->t - slow->t) <= tol && fast->mediumFrom == slow->mediumFrom &&
               fast->mediumTo == slow->mediumTo;
    }
    if (!same) {
        if (m.count == 0) {
            std::ostringstream os;
            os << ray << " from object " << startObject << ": fast ";
            if (fast)
                os << *fast << " (" << scene.object(fast->object).name << ")";
            else
                os << "miss";
            os << ", brute force ";
            if (slow)
                os << *slow << " (" << scene.object(slow->object).name << ")";
            else
                os << "miss";
            m.first = os.str();
        }
        ++m.count;
    }
}

// Where the rays go. The brute-force oracle costs ~20 ns per triangle per ray, so rays are
// spent where closestHit can go wrong rather than spread at random. In turn, a primary ray
// starts at a random point in and around the lens in a random direction (misses and long
// paths included), or passes through a point of a random object's tessellation (each object
// equally often, however small: flats, stop edge, retainers): inside a triangle, next to a
// triangle edge (mesh seams; rims where a lens face meets its flat or edge cylinder, aimed
// just inside or just outside), or next to a vertex (where several triangles or faces meet).
// "Next to" is 1e-5 to 1e-3 of the scene's size: far beyond float rounding (Embree's
// candidates are float), so the answer is well defined, and close enough that a seam or a
// face bound off by that much shows. Every hit continues from the point it hit, starting on
// that object and triangle (the tracer's case), in a random direction or toward a target on
// another object. A continuation within 1 degree of its face's plane is replaced by a random
// direction: aimed at a coplanar face (a retainer against its seat, a flat at a step of the
// bore), it would run inside that plane and meet triangles edge-on, where rounding, not
// closestHit, decides the answer (without this rule, 1 to 4 such rays per example differ).
class TargetPicker {
  public:
    TargetPicker(const Scene& scene, uint64_t seed) : rng_(seed) {
        std::vector<int> objectOfTriangle;
        targets_ = scene.tessellate(0.05, &objectOfTriangle);
        trianglesOf_.resize(scene.objects().size());
        for (size_t t = 0; t < objectOfTriangle.size(); ++t)
            trianglesOf_[objectOfTriangle[t]].push_back(static_cast<uint32_t>(t));
        for (size_t o = 0; o < trianglesOf_.size(); ++o)
            if (!trianglesOf_[o].empty()) objects_.push_back(static_cast<int>(o));
        box_ = scene.bounds();
        const Vec3 pad = 0.1 * (box_.hi - box_.lo);
        box_.lo -= pad;
        box_.hi += pad;
        sizeMm_ = glm::length(box_.hi - box_.lo);
    }

    Vec3 origin() {
        return {box_.lo.x + u() * (box_.hi.x - box_.lo.x),
                box_.lo.y + u() * (box_.hi.y - box_.lo.y),
                box_.lo.z + u() * (box_.hi.z - box_.lo.z)};
    }

    Vec3 randomDirection() {
        std::normal_distribution<double> n;
        Vec3 d;
        do d = Vec3(n(rng_), n(rng_), n(rng_));
        while (glm::length(d) < 1e-6);
        return glm::normalize(d);
    }

    // kind 0: inside a triangle, 1: next to an edge, 2: next to a vertex; on any object but
    // `avoid`.
    Vec3 target(int kind, int avoid) {
        int object = avoid;
        while (object == avoid) object = objects_[pick(objects_.size())];
        const std::vector<uint32_t>& tris = trianglesOf_[object];
        const auto& tri = targets_.triangles[tris[pick(tris.size())]];
        const size_t corner = pick(3);
        const Vec3& a = targets_.vertices[tri[corner]];
        const Vec3& b = targets_.vertices[tri[(corner + 1) % 3]];
        const Vec3& c = targets_.vertices[tri[(corner + 2) % 3]];
        const double offset = sizeMm_ * std::pow(10.0, -5.0 + 2.0 * u());
        if (kind == 2) return a + offset * randomDirection();
        const double s = u();
        if (kind == 1) {
            // Across the edge a-b, in the triangle's plane, to either side.
            const Vec3 across = glm::normalize(glm::cross(glm::cross(b - a, c - a), b - a));
            return a + s * (b - a) + (u() < 0.5 ? offset : -offset) * across;
        }
        const double r = std::sqrt(u());  // uniform over the triangle
        return (1.0 - r) * a + r * ((1.0 - s) * b + s * c);
    }

    // The i-th primary ray: from a random point in the box in a random direction, or through
    // a target of kind i % 4 - 1 from a random direction, starting 0.3 % to 30 % of the
    // scene's size before it (so targets inside the barrel are reached, not only the barrel).
    Ray primary(int i) {
        if (i % 4 == 0) return {origin(), randomDirection()};
        const Vec3 t = target(i % 4 - 1, -1), d = randomDirection();
        return {t - sizeMm_ * std::pow(10.0, -2.5 + 2.0 * u()) * d, d};
    }

    // The i-th continuation from a hit: random, or toward a target on another object.
    Vec3 continuation(const SceneHit& h, int i) {
        if (i % 4 == 0) return randomDirection();
        const Vec3 d = glm::normalize(target(i % 4 - 1, h.object) - h.point);
        if (std::abs(glm::dot(d, h.normal)) < std::sin(M_PI / 180.0)) return randomDirection();
        return d;
    }

    double axisZ() { return box_.lo.z + u() * (box_.hi.z - box_.lo.z); }

  private:
    double u() { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_); }
    size_t pick(size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng_); }

    std::mt19937_64 rng_;
    TriangleMesh targets_;                            // the scene tessellated, global
    std::vector<std::vector<uint32_t>> trianglesOf_;  // [object id] -> its triangles
    std::vector<int> objects_;                        // ids of objects with triangles
    Bounds3 box_;
    double sizeMm_ = 0.0;  // diagonal of box_
};

// Every example with mechanics: the lens files with the default mechanics at a coarse
// tessellation, the scene files with their own; and four test lenses, one with odd asphere
// terms, one with Q-type faces (Qbfs and Qcon), one tilted and decentered by a coordinate
// break (exact faces on two axes) with [[mesh]] blocks beside it, and crossed cylinder
// lenses (toroidal faces, edges ending on their curved rims) with blocks beside them. The double
// Gauss with default mechanics (6 lenses, 25 exact faces, ~4000 triangles) gets 1e5 rays; the
// others, whose faces and parts it shares in kind, fewer, in proportion to what their triangles
// cost the oracle.
struct OracleCase {
    const char* name;     // the test's name: stable, whatever the file layout
    const char* example;  // under examples/, without .toml
    int rays;             // rays compared, primary and continuation together
};
void PrintTo(const OracleCase& c, std::ostream* os) { *os << c.name; }

class SceneClosestHit : public ::testing::TestWithParam<OracleCase> {};

TEST_P(SceneClosestHit, AgreesWithBruteForce) {
    const SceneGeometry setup = exampleScene(GetParam().example);
    const Scene& scene = setup.scene;
    ASSERT_GT(scene.meshes().size(), 0u) << "no mechanics were built";
    TargetPicker aim(scene, 20261122);
    Mismatch m;
    int hits = 0, compared = 0, primaries = 0, continuations = 0, sealedRays = 0;
    while (compared < GetParam().rays) {
        const Ray ray = aim.primary(primaries++);
        std::optional<SceneHit> hit;
        compare(scene, ray, -1, -1, m, &hit);
        ++compared;
        if (!hit) {
            // Aim at the axis instead so the second ray still starts on something.
            const Vec3 target(0.0, 0.0, aim.axisZ());
            compare(scene, {ray.origin, glm::normalize(target - ray.origin)}, -1, -1, m, &hit);
            ++compared;
        }
        if (!hit) continue;
        ++hits;
        // The continuation travels in the medium on the side it leaves toward: the tracer's
        // case, a ray inside a lens body searching the exact faces alone.
        const Vec3 d = aim.continuation(*hit, continuations++);
        const SceneObject& o = scene.object(hit->object);
        const int medium = glm::dot(d, hit->normal) < 0.0 ? o.mediumBack : o.mediumFront;
        if (scene.sealed(medium)) ++sealedRays;
        compare(scene, {hit->point, d}, hit->object, hit->primitive, m, nullptr, medium);
        ++compared;
    }
    // Every glass is sealed (no part comes near a lens body), so the rays above in glass took
    // the exact faces alone.
    EXPECT_TRUE(scene.bodiesNotClear().empty()) << scene.bodiesNotClear().front();
    for (size_t k = 1; k < scene.media().size(); ++k)
        EXPECT_TRUE(scene.sealed(static_cast<int>(k))) << scene.media()[k].name;
    EXPECT_GT(sealedRays, compared / 20);
    EXPECT_EQ(m.count, 0) << m.count << " of " << compared << " rays differ; first: " << m.first;
    EXPECT_EQ(m.faceCount, 0) << m.faceCount << " face hits differ; first: " << m.faceFirst;
    EXPECT_GT(m.faceHits, compared / 10);    // rays whose nearest hit is an exact face
    EXPECT_GT(m.faceBeyond, compared / 10);  // faces met behind something nearer
    EXPECT_GT(hits, compared / 4);  // the rays do meet the scene
    // Every object is hit, the small ones (stop edge, flats, spacers) included.
    const SceneObject* least = nullptr;
    for (const SceneObject& o : scene.objects()) {
        EXPECT_GE(m.hitsOnObject[o.id], 10) << o.name << " is hardly ever hit";
        if (!least || m.hitsOnObject[o.id] < m.hitsOnObject[least->id]) least = &o;
    }
    std::cout << "[ measured ] " << compared << " rays, " << hits << " primary hits, " << sealedRays
              << " in sealed glass, least hit: " << least->name << " (" << m.hitsOnObject[least->id]
              << ")\n";
}

INSTANTIATE_TEST_SUITE_P(
    Examples, SceneClosestHit,
    ::testing::Values(
        OracleCase{"singlet_default_mechanics", "lenses/singlet", 20000},
        OracleCase{"odd_asphere_singlet", "../tests/data/toml/odd_asphere_singlet", 20000},
        OracleCase{"tilted_doublet_meshes", "../tests/data/toml/tilted_doublet", 20000},
        OracleCase{"qtype_singlet", "../tests/data/toml/qtype_singlet", 20000},
        OracleCase{"crossed_cylinders", "../tests/data/toml/crossed_cylinders", 20000},
        OracleCase{"achromat_default_mechanics", "lenses/achromat", 20000},
        OracleCase{"cooke_triplet_default_mechanics", "lenses/cooke_triplet", 20000},
        OracleCase{"double_gauss_default_mechanics", "lenses/double_gauss_50mm", 100000},
        OracleCase{"longfocus_default_mechanics", "lenses/longfocus_360mm", 20000},
        OracleCase{"catadioptric_default_mechanics", "lenses/catadioptric_2000mm", 20000},
        OracleCase{"double_gauss_scene", "scenes/double_gauss_50mm", 20000},
        OracleCase{"longfocus_scene", "scenes/longfocus_360mm", 10000},
        OracleCase{"catadioptric_scene", "scenes/catadioptric_2000mm", 10000}),
    [](const ::testing::TestParamInfo<OracleCase>& param) { return param.param.name; });

}  // namespace
}  // namespace veil
