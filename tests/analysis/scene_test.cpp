// The assembled scene of every example lens with mechanics: closest hit against a brute-force
// loop over every exact face and every triangle, for random rays and for rays that start on
// the surface they just hit (the nonsequential tracer's case).

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

#include "analysis/scene_setup.h"

namespace veil {
namespace {

// An example: "scenes/x" as written (with its own [mechanics]), "lenses/x" with the default
// mechanics at a coarser tessellation (the brute-force oracle is slow on fine meshes).
SceneSetup exampleScene(const std::string& name) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    SceneFile f = readSceneFile(VEIL_SOURCE_DIR "/examples/" + name + ".toml", catalog);
    if (!f.mechanics) {
        MechanicsSpec spec;
        spec.chordToleranceMm = 0.05;
        f.mechanics = spec;
    }
    return buildScene(f, catalog);
}

Vec3 randomDirection(std::mt19937_64& rng) {
    std::normal_distribution<double> n;
    Vec3 d;
    do d = Vec3(n(rng), n(rng), n(rng));
    while (glm::length(d) < 1e-6);
    return glm::normalize(d);
}

struct Mismatch {
    int count = 0;
    std::string first;
};

void compare(const Scene& scene, const Ray& ray, int startObject, int startPrimitive, Mismatch& m,
             std::optional<SceneHit>* hitOut) {
    const auto fast = scene.closestHit(ray, kInfinity, startObject, startPrimitive);
    const auto slow = scene.closestHitBruteForce(ray, kInfinity, startObject, startPrimitive);
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

// 1e5 rays per example: half from random points in and around the lens toward random
// directions, half continuing from the point they hit, in a new random direction, starting
// on that object (and triangle).
class SceneClosestHit : public ::testing::TestWithParam<const char*> {};

TEST_P(SceneClosestHit, AgreesWithBruteForce) {
    const SceneSetup setup = exampleScene(GetParam());
    const Scene& scene = setup.scene;
    ASSERT_GT(scene.meshes().size(), 0u) << "no mechanics were built";
    Bounds3 b = scene.bounds();
    const Vec3 pad = 0.1 * (b.hi - b.lo);
    b.lo -= pad;
    b.hi += pad;
    std::mt19937_64 rng(20261122);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Mismatch m;
    int hits = 0, compared = 0;
    // At least 1e5 rays compared: primary rays, and a continuation from every hit.
    while (compared < 100000) {
        const Vec3 o(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                     b.lo.z + u(rng) * (b.hi.z - b.lo.z));
        std::optional<SceneHit> hit;
        compare(scene, {o, randomDirection(rng)}, -1, -1, m, &hit);
        ++compared;
        if (!hit) {
            // Aim at the axis instead so the second ray still starts on something.
            const Vec3 target(0.0, 0.0, b.lo.z + u(rng) * (b.hi.z - b.lo.z));
            compare(scene, {o, glm::normalize(target - o)}, -1, -1, m, &hit);
            ++compared;
        }
        if (!hit) continue;
        ++hits;
        compare(scene, {hit->point, randomDirection(rng)}, hit->object, hit->primitive, m, nullptr);
        ++compared;
    }
    EXPECT_EQ(m.count, 0) << m.count << " of " << compared << " rays differ; first: " << m.first;
    EXPECT_GT(hits, compared / 4);  // the rays do meet the scene
}

INSTANTIATE_TEST_SUITE_P(Examples, SceneClosestHit,
                         ::testing::Values("lenses/singlet", "lenses/achromat",
                                           "lenses/cooke_triplet", "lenses/double_gauss_50mm",
                                           "lenses/longfocus_360mm", "lenses/catadioptric_2000mm",
                                           "scenes/double_gauss_50mm", "scenes/longfocus_360mm",
                                           "scenes/catadioptric_2000mm"),
                         [](const ::testing::TestParamInfo<const char*>& info) {
                             std::string n = info.param;
                             for (char& c : n)
                                 if (c == '/') c = '_';
                             return n;
                         });

}  // namespace
}  // namespace veil
