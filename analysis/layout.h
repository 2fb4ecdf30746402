#pragma once
// 2D layout: the y-z section of lens elements, mechanics, stop and detector, with the
// optical axis, part labels and a scale bar. Glass is filled light blue, mechanical parts
// grey, the stop black, imported meshes olive, the detector is a red line.

#include <string>

#include "analysis/picture.h"
#include "geometry/scene.h"

namespace veil {

struct LayoutOptions {
    double chordToleranceMm = 0.005;  // section sampling of exact faces
    bool labels = true;
    std::string title;
};

// A picture of the scene's section; more layers (ray paths) can be drawn on it afterwards.
Picture drawLayout(const Scene& scene, const LayoutOptions& options);

}  // namespace veil
