#pragma once
// The scene veil makes of a bare lens file: the light sources of its fields, and for the
// ghost analysis a detector at the paraxial image and a stop plate. Every command that traces
// starts from it when the file has no [[source]] (prepareTracedScene).

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tracer/scene/scene_geometry.h"

namespace veil {

class GlassCatalog;
class PreparedScene;

// The default scene of a bare lens file (no [[source]]): one collimated 1 W source per
// system field (object at infinity) or one point source per field point (finite object),
// each filling the first surface, at the system wavelengths and weights; an absorbing stop
// plate (no barrel); the image surface moved to the paraxial image plane of the primary
// wavelength (unless the lens is afocal), with the detector on it. Changes `file` in place;
// returns false (and does nothing) when the file has sources. `imageShiftMm` (may be null):
// how far the image surface moved along z.
bool addDefaultGhostScene(SceneSpec& spec, const GlassCatalog& catalog,
                          double* imageShiftMm = nullptr);

// A scene without [[source]] gets one collimated (or point) 1 W source per system field, as
// setFieldSources() makes them, and nothing else changes; returns the fields used, empty
// (and does nothing) when the file has sources.
std::vector<std::pair<double, double>> addSystemFieldSources(SceneSpec& spec,
                                                             const GlassCatalog& catalog);

// Collimated sources replacing the scene's: one per field (degrees x, y), 1 W each.
void setFieldSources(SceneSpec& spec, const GlassCatalog& catalog,
                     const std::vector<std::pair<double, double>>& fieldsDeg);

// The scene of a command that traces, built once: the file's sources replaced by one beam per
// field of `fieldsDeg` when it is not empty (setFieldSources); a file without [[source]] gets
// one per system field (addSystemFieldSources), and `note` (when not null) then says what
// was added, for the user. `note` is cleared otherwise.
std::unique_ptr<PreparedScene> prepareTracedScene(
    SceneSpec spec, const GlassCatalog& catalog,
    const std::vector<std::pair<double, double>>& fieldsDeg, const SceneOptions& options = {},
    std::string* note = nullptr);

}  // namespace veil
