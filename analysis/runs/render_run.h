#pragma once
// A render as a value, for studies: a prepared scene rendered for a fixed number of passes
// (veil render's method, tracer/render/render.h), each pass's totals handed out as it finishes.
//
//   PreparedScene + RenderRunSpec (options, passes, detector, criteria)
//     --runRenderPasses--> per pass: the flux on the detector per component (visible,
//       direct, caustic, secondary) and per criterion
//
// The mean of the passes' totals is the render's estimate, and the spread of the passes
// gives its error (as RenderState does per pixel). Pass k draws the same random streams
// (passSeed) in every scene: two scenes rendered with the same spec share their random
// numbers, as the sweeps' batches do.

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "tracer/render/render.h"
#include "tracer/scene/prepared_scene.h"

namespace veil {

struct RenderRunSpec {
    RenderOptions options;  // initialRadiusMm 0: defaultInitialRadius() of the scene
    int passes = 8;
    std::string detector;            // empty: the first
    std::vector<std::string> where;  // path criteria on the joined path (render --where)
};

struct RenderPassTotals {
    std::array<double, kRenderComponents> components{};  // flux on the detector
    std::vector<double> criteria;                        // per criterion, all components
    const RenderPass* pass = nullptr;  // the pass itself (its pixels), during the call only
    double total() const;
};

// The index of the detector named `name` among trace.images (empty: the first, 0); ParseError
// at --detector naming the scene's detectors when none has that name.
size_t findDetector(const TraceSetup& trace, const std::string& name);

// The detector rendered (its name is returned). Throws ParseError for a criterion or detector
// name that names nothing and ModelError for a scene with no source, no detector or nothing
// that scatters, before the first pass.
std::string runRenderPasses(const PreparedScene& scene, const RenderRunSpec& spec,
                            const std::function<void(int pass, const RenderPassTotals&)>& onPass);

}  // namespace veil
