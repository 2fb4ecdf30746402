#pragma once
// Point source transmittance: how much of a distant point source's light reaches the detector,
// against the source's angle off the axis.
//
//   PST(theta) = flux on the detector / flux incident on the entrance pupil
//
// for a uniform collimated beam at the angle theta (azimuth phi: the field is
// (theta sin phi, theta cos phi) degrees, phi = 0 in the y-z plane) that fills the first
// surface out to its aperture radius (mech_sd, else sd), so the mounts around the first
// element are lit too; the incident flux is what the beam brings through a disk of the
// paraxial entrance pupil's diameter. A lens with its stop at 0 degrees has PST = its
// transmittance. The irradiance form (detector irradiance over the beam's irradiance
// normal to it) is PST times the pupil's area, cos(theta), over the detector's area; the
// CSV carries both.
//
// Every angle is traced forward in batches with the same seeds (as veil sweep does), on
// geometry built once (only the source changes). The light is split into the nominal image
// (`not fresnel and not scatter`: refracted and mirrored only), the stray light (`fresnel or
// scatter`), and the user's criteria; inside the field of view (the system's largest field
// angle) the nominal image is the signal and the stray light is what PST plots. Rendered
// instead (render), the split is the renderer's: the specular light (the visible component:
// the nominal image and the ghosts) and the scattered light (direct, caustic and secondary),
// plus the criteria. Every angle also gets the sequential estimate of all two-reflection
// ghosts (veil ghosts' estimate, deterministic and fast; the mechanics are not in it):
// where it fits (ghosts that no mount cuts), it is the ghost curve without noise.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "analysis/reports/progress.h"
#include "analysis/reports/report_table.h"
#include "tracer/render/render.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

class GlassCatalog;

struct PstSpec {
    std::filesystem::path scene;
    std::vector<SceneEdit> edits;  // applied when the scene is read (`--set`)
    // Forward Monte Carlo (the default), or the bidirectional renderer: `batches` passes per
    // angle with these options (its seed is transport.seed), for scenes where the stray light
    // is scatter from dark mounts that forward rays find only as speckle.
    bool render = false;
    RenderOptions renderOptions;
    std::vector<double> anglesDeg;  // off-axis angles, >= 0 and < 90
    double azimuthDeg = 0.0;
    uint64_t raysPerAngle = 0;
    int batches = 16;
    TransportOptions transport;      // its seed is the first batch's
    std::vector<std::string> where;  // more criteria, each its own PST curve
    // Before each angle and after each batch: one task per angle, "pst: angle 2 of 9 (10 deg)",
    // its batches counted.
    ProgressSink progress;
    // Under mpirun (tracer/runtime/ranks.h): angle a is measured on rank a mod K by that rank
    // alone, and rank 0 gets every row (the others return theirs empty).
    Ranks ranks = Ranks::alone();
};

struct PstQuantity {
    std::string name;       // "total", "nominal", "stray", "where1", ...
    std::string criterion;  // "" for the total
};

struct PstRow {
    double angleDeg = 0.0;
    bool inField = false;            // within the system's largest field angle
    std::vector<double> pst, error;  // per quantity: PST and its 1-sigma error
};

struct PstResult {
    std::string measure;  // "trace" or "render"
    std::vector<PstQuantity> quantities;
    std::vector<PstRow> rows;
    double fieldDeg = 0.0;         // the system's largest field angle
    double apertureAreaMm2 = 0.0;  // the entrance pupil's, pi r^2
    double pupilRadiusMm = 0.0;    // paraxial entrance pupil, primary wavelength
    double beamRadiusMm = 0.0;     // the beam's radius over the first surface
    double detectorAreaMm2 = 0.0;
    std::string detector;

    // One row per angle: its PST and error per quantity (analysis/reports/report_table.h);
    // the files below are written from it.
    ReportTable table() const;
    std::string csv() const;
    std::string markdown() const;
    std::string json() const;
};

// Throws ParseError for a bad angle or criterion and ModelError for a scene that cannot be
// built, before the first ray.
PstResult runPst(const PstSpec& spec, const GlassCatalog& catalog);

// pst.csv, pst.md, pst.json, pst.png and pst.svg (PST against the angle, log scale, a line
// per quantity, error bars; the field's edge marked). Returns the paths.
std::vector<std::filesystem::path> writePst(const PstResult& result,
                                            const std::filesystem::path& folder);

}  // namespace veil
