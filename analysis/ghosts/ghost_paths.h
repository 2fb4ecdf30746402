#pragma once
// Ghost paths of a lens and the criteria that name them.
//
// Ghost surfaces. A ghost reflection is the weak specular reflection of a refracting
// surface: every sequential surface where the refractive index changes (air-glass and
// cemented glass-glass interfaces; N of them). Mirrors are not ghost surfaces (their
// unwanted light is transmission, which leaves the sequential path) but ghost paths cross
// them as mirrors, both ways. Dummy surfaces and the stop in air are not ghost surfaces.
//
// Ghost paths. A two-reflection ghost (i, j), j < i, goes forward through surfaces 1..i-1,
// reflects at i, runs backward through i-1..j+1, reflects at j and runs forward through
// j+1.. to the image: N(N-1)/2 of them. A four-reflection ghost (i, j, k, l) reflects at i,
// then j < i, then k > j, then l < k; those whose product of normal-incidence reflectances
// falls below GhostOptions::minFourthOrderReflectance are pruned before tracing.
//
// Generated criterion (docs/criteria.md) of ghost (i, j) on detector D:
//   seq(fresnel(Si), fresnel(Sj)) and fresnel{2} and not scatter and not tir and detector(D)
// exactly two Fresnel reflections, at Si then Sj, nothing scattered, no total internal
// reflection, recorded by D. The same text drives the Monte Carlo binning (veil ghosts),
// veil trace --where and veil paths --where.
//

#include <ostream>
#include <string>
#include <vector>

namespace veil {

class SequentialModel;

// One ghost path: its reflections in time order (sequential surface indices).
struct GhostPath {
    std::vector<int> reflections;
    std::vector<std::string> names;  // object names of those surfaces
    std::string label;               // "L4.back > L4.front"
    std::string criterion;           // generated criterion text
    int order() const { return static_cast<int>(reflections.size()); }
};
std::ostream& operator<<(std::ostream& os, const GhostPath& g);

// Sequential indices of the ghost surfaces of a model (see the header comment), in order.
std::vector<int> ghostSurfaces(const SequentialModel& model);

// The criterion of a ghost path with these reflection names on detector `detector`, and of
// the nominal image (no Fresnel reflection, scatter or TIR).
// A path that crosses mirrors (mirrorReflections > 0) also requires exactly that many
// specular reflections besides its Fresnel ones (reflect{n}), so light that skips the
// mirrors (through a Cassegrain's central hole) is not counted as that path; `firstFace`
// (when not empty) requires a refraction at the first lens face, so light that passes beside
// the lens (when a stop or aperture ring before it is larger) is not counted either.
std::string ghostCriterion(const std::vector<std::string>& reflectionNames,
                           const std::string& detector, int mirrorReflections = 0,
                           const std::string& firstFace = "");
std::string nominalCriterion(const std::string& detector, int mirrorReflections = 0,
                             const std::string& firstFace = "");
// Every ghost of the given order or less (2 or 4) together: the sum of the ghost criteria
// (for a lens without mirrors).
std::string allGhostsCriterion(int order, const std::string& detector,
                               const std::string& firstFace = "");

}  // namespace veil
