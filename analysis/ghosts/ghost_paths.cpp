#include "analysis/ghosts/ghost_paths.h"

#include <cmath>

#include "analysis/reports/format.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const GhostPath& g) {
    return os << "GhostPath{" << g.label << ", " << g.criterion << "}";
}

std::vector<int> ghostSurfaces(const SequentialModel& model) {
    std::vector<int> out;
    const int w = model.primaryWavelength();
    for (int s = 1; s < model.imageIndex(); ++s) {
        if (model.surface(s).mirror) continue;
        const double n1 = std::abs(model.index(s - 1, w));
        const double n2 = std::abs(model.index(s, w));
        if (std::abs(n1 - n2) > 1e-12 || !(model.prescription().surfaces[s - 1].material ==
                                           model.prescription().surfaces[s].material))
            out.push_back(s);
    }
    return out;
}

namespace {

// The conditions every criterion of a path shares besides its reflections.
std::string pathConditions(int reflections, int mirrorReflections, const std::string& firstFace,
                           const std::string& detector) {
    std::string text = " and not scatter and not tir";
    if (mirrorReflections > 0)
        text += " and reflect{" + std::to_string(reflections + mirrorReflections) + "}";
    if (!firstFace.empty()) text += " and refract(" + firstFace + ")";
    return text + " and detector(" + detector + ")";
}

}  // namespace

std::string ghostCriterion(const std::vector<std::string>& names, const std::string& detector,
                           int mirrorReflections, const std::string& firstFace) {
    std::vector<std::string> leaves;
    for (const std::string& n : names) leaves.push_back("fresnel(" + n + ")");
    const int n = static_cast<int>(names.size());
    return "seq(" + join(leaves, ", ") + ") and fresnel{" + std::to_string(n) + "}" +
           pathConditions(n, mirrorReflections, firstFace, detector);
}

std::string allGhostsCriterion(int order, const std::string& detector,
                               const std::string& firstFace) {
    std::string count = "fresnel{2}";
    for (int k = 4; k <= order; k += 2) count += " or fresnel{" + std::to_string(k) + "}";
    if (order > 2) count = "(" + count + ")";
    return count + pathConditions(0, 0, firstFace, detector);
}

std::string nominalCriterion(const std::string& detector, int mirrorReflections,
                             const std::string& firstFace) {
    return "not fresnel" + pathConditions(0, mirrorReflections, firstFace, detector);
}

}  // namespace veil
