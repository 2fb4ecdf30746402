#include "analysis/lens/detector_checks.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "analysis/lens/first_order.h"
#include "geometry/lens_solid.h"
#include "tracer/records/detector.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

namespace {

std::string mm(double v) {
    std::ostringstream os;
    os << std::setprecision(std::abs(v) >= 100.0 ? 5 : 4) << v << " mm";
    return os.str();
}

// Distance from the axis (x = y = 0) to the nearest point of the rectangle centred at
// (cx, cy) with half sizes hx, hy.
double axisDistance(double cx, double cy, double hx, double hy) {
    const double dx = std::max(0.0, std::abs(cx) - hx), dy = std::max(0.0, std::abs(cy) - hy);
    return std::hypot(dx, dy);
}

}  // namespace

std::vector<ImportNote> detectorPlacementWarnings(const SceneSpec& file,
                                                  const SceneGeometry& setup) {
    std::vector<ImportNote> out;
    // The checks measure along one axis: a system a coordinate break tilts or decenters
    // is not checked.
    if (!setup.model || !setup.model->coaxial()) return out;
    const SequentialModel& model = *setup.model;
    const FirstOrderData fo = computeFirstOrder(model, model.primaryWavelength());
    const double efl = fo.eflMm;
    const double zImage = model.surface(model.imageIndex()).zMm + fo.paraxialImageDistanceMm;
    // An imaging lens: finite focal length and a paraxial image at a finite distance.
    const bool imaging = std::isfinite(efl) && efl != 0.0 && std::isfinite(zImage);
    double imageRadius = 0.0;
    for (double h : fo.paraxialImageHeightsMm)
        if (std::isfinite(h)) imageRadius = std::max(imageRadius, std::abs(h));
    const double tolerance = std::max(1.0, 0.02 * std::abs(efl));
    const std::vector<LensSolid> solids = lensSolids(setup.prescription);
    // Image space: light travels toward +z (direction +1) or, after an odd number of
    // mirrors, toward -z.
    const double imageDirection = model.direction(model.imageIndex() - 1);

    for (size_t d = 0; d < setup.detectors.size(); ++d) {
        const DetectorGeometry& g = setup.detectors[d];
        ImportNote note;
        note.severity = ImportNote::Severity::Warning;
        note.loc =
            d < file.detectors.size() ? file.detectors[d].loc : FileLoc{file.path.string(), 0, 0};
        const std::string who = "detector '" + g.name + "'";
        auto warn = [&](const std::string& message) {
            note.message = who + " " + message;
            out.push_back(note);
        };
        const Vec3 c = g.frame.translation;
        const double r = std::hypot(c.x, c.y);

        bool inGlass = false;
        for (const LensSolid& s : solids) {
            if (r > s.edgeRadiusMm) continue;
            const double zf = s.frontZAt(c.x, c.y), zb = s.backZAt(c.x, c.y);
            const double z0 = std::min(zf, zb), z1 = std::max(zf, zb);
            // An image inside the medium (endImmersedImage): a detector on the image lies
            // inside the glass by design, the medium ending just behind it.
            const bool immersed = s.back.surface == model.imageIndex() &&
                                  std::abs(c.z - zb) <= 1.5 * kImmersedImageClearanceMm;
            if (c.z > z0 && c.z < z1 && !immersed) {
                warn("(centre at z = " + mm(c.z) + ") lies inside lens element " + s.name +
                     ", whose glass runs from z = " + mm(z0) + " to " + mm(z1) +
                     " there: the light it records has not left the element; place it with "
                     "z_mm behind the lens or on the sensor");
                inGlass = true;
            }
        }
        if (!imaging || inGlass) continue;
        const double dz = c.z - zImage;
        if (std::abs(dz) > tolerance) {
            warn("(at z = " + mm(c.z) + ") is " + mm(std::abs(dz)) +
                 (dz * imageDirection < 0.0 ? " before" : " behind") +
                 " the paraxial image plane (z = " + mm(zImage) + ", EFL " + mm(efl) +
                 "): what it records is out of focus" +
                 (c.z < model.surface(1).zMm ? ", and in front of the lens" : ""));
            continue;
        }
        const double hx = 0.5 * g.widthMm, hy = 0.5 * g.heightMm;
        const double gap = axisDistance(c.x, c.y, hx, hy);
        if (imageRadius > 0.0 && gap > 1.1 * imageRadius)
            warn("lies " + mm(gap) + " from the axis at its nearest, outside the image circle " +
                 "of the system's fields (radius " + mm(imageRadius) + "): no field point is " +
                 "imaged on it");
        if (glm::dot(Vec3(0.0, 0.0, imageDirection), g.normal()) > 0.0)
            warn(
                "faces away from the image-space light, which arrives on its back: the image "
                "is recorded as seen from behind (x mirrored)");
    }
    return out;
}

}  // namespace veil
