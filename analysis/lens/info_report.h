#pragma once
// What veil info reports of a lens: first-order data per wavelength (and of the x-z section of
// an anamorphic lens), the surfaces and elements, spot sizes per field and wavelength, and the
// import report, and whether it builds into a scene. A value, written as JSON or as the terminal
// text; nothing here prints.
//
//   Prescription + GlassCatalog --makeInfoReport--> InfoReport --json() / text()-->

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/lens/first_order.h"
#include "analysis/lens/spot.h"
#include "geometry/lens_fit.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/ray_aiming.h"

namespace veil {

class GlassCatalog;
class SequentialModel;

// Whether the lens builds into a scene as veil trace builds it: its solids (sized to fit
// where the file's sizes do not build, geometry/lens_fit.h), the mechanics of a scene file,
// the stop plate of a bare lens.
struct SceneBuildCheck {
    bool built = false;
    std::string error;  // what stopped the build
    int elements = 0, objects = 0, mechanicalParts = 0;
    std::vector<LensSizeChange> sizeChanges;
    std::vector<std::string> notes;  // what the build left out or changed besides
};

struct InfoReport {
    std::string file;  // as the user named it
    Prescription prescription;
    std::shared_ptr<const SequentialModel> model;
    FirstOrderReport firstOrder;
    std::optional<FirstOrderData> xSection;  // anamorphic lenses: the x-z section's data
    AimMode aim = AimMode::Real;
    int rings = 8;
    std::vector<SpotResult> spots;  // field-major, every wavelength of each field
    std::optional<SceneBuildCheck> build;

    // The primary wavelength's first-order data at the top level (efl_mm, bfl_mm, ...), every
    // wavelength under "wavelengths", surfaces, elements, spots and the import report beside.
    nlohmann::json json() const;
    std::string text() const;
};

// Spots of `rings` hexapolar rings, aimed as `aim` says.
InfoReport makeInfoReport(const std::string& file, Prescription prescription,
                          const GlassCatalog& catalog, AimMode aim, int rings);

}  // namespace veil
