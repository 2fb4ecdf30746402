#pragma once
// Veiling glare (`veil glare`): the veiling glare index of ISO 9358, computed from the lens
// model with its mechanics and finishes instead of measured.
//
// The test field is a uniform Lambertian field filling the object space out to
// fieldHalfAngleDeg about the axis (the integrating sphere of the measurement) with a black
// spot of spotDiameterDeg at the field position under test. The VGI is the irradiance at the
// centre of the spot's image over the irradiance there when the spot is as bright as the rest:
//
//   VGI = E_black / E_white
//
// Both are rendered (tracer/render/render.h, veil render's method) on a small detector at the
// spot's image (its centre from the real chief ray, its size from the image of the spot: a square
// of side half the spot image's radius, so that the blur of the spot's rim stays outside it
// unless the lens blurs by more than 0.6 of that radius):
// the field is a window source in front of the lens, and E_black's source has the black spot
// (AreaEmitter::blackSpotAxis). The render's components and two path criteria split E_black
// into
//   specular  light that reached the detector through reflections and refractions alone, with
//             at least one Fresnel or total internal reflection: the ghosts, found by backward
//             rays split at every interface (the visible component); among them (tir) those
//             with a total internal reflection, which light of a wide field finds at steep
//             faces and the sequential ghost analysis does not enumerate;
//   blur      the visible light with neither: the lens's own image of the bright field around
//             the spot, blurred into its centre by aberrations (the spot is too small for the
//             lens; the report says so when it is 5 % of the VGI or more);
//   diffuse   light that scattered on the way (mounts, lens edges, rough or dusty surfaces:
//             the direct, caustic and secondary components).
// With nothing that reflects or scatters and a spot wider than the blur, E_black is 0 exactly.
// Errors come from the spread of the render's passes (1 sigma) and are carried through the
// ratio.
//
// The field's spectrum: the lens's wavelengths and weights, V(lambda)-weighted (photometric)
// when the eye sees every line, else radiometric; the result states which.
//
// The glare spread function (GSF) at the positions GlareSpec::spread names: the irradiance at
// distance r from the image of a point source at the position's direction (a collimated beam
// overfilling the port, the field's spectrum), averaged over azimuth, over the flux the source
// brings to a disc of radius R about its image (so it integrates to 1 over the disc; unit 1/mm^2),
// with its specular and diffuse parts. Rendered on two square detectors centred on the chief ray's
// landing point: a coarse one of side 2R and a fine one of side 8 rho (rho the spot image's radius)
// for r < 3.8 rho, each pixel split into 4 x 4 parts among the annuli. From it the VGI is
// recomputed as ISO 9358 does when the GSF is the same everywhere in the image (isoplanatic): the
// share of the disc's flux that lands outside rho, which is the VGI of a bright field whose image
// is the disc. On axis, where the disc is the image of a cone of the field about the axis (theta_R,
// the real chief ray's angle at height R), veil also renders that VGI directly, as the check. They
// agree where the stray light moves with the image (scatter at or near the stop); a ghost moves
// across the image at its own rate (its magnification m_g against the image's), so a point source's
// ghost light lands spread over the disc while a bright field's ghosts pile up at the spot image in
// the ratio 1/m_g^2: there the two differ, and the direct measurement is the VGI.

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "analysis/pictures/chart.h"
#include "analysis/reports/progress.h"
#include "analysis/reports/report_table.h"
#include "geometry/vec.h"
#include "tracer/render/render.h"
#include "tracer/scene/scene_spec.h"

namespace veil {

class SpectralSampler;
class RayAimer;
class GlassCatalog;

class GhostTracer;    // analysis/ghosts/ghosts.h
class PreparedScene;  // tracer/scene/prepared_scene.h

enum class GlareSpreadAt { None, Axis, All };

struct GlareSpec {
    std::vector<Vec2> fieldsDeg;      // spot positions; empty: the axis and the lens's fields
    double spotDiameterDeg = 0.5;     // angular diameter of the black spot
    double fieldHalfAngleDeg = 80.0;  // the bright field: a cone about the axis
    // Apertures: the stop stopped down (its semi-diameter scaled) to these image-space
    // F-numbers, each measured at every position; empty: the lens as given. Needs a stop plate
    // ([mechanics] stop) and F-numbers no faster than the lens's own.
    std::vector<double> fNumbers;
    int passes = 8;
    int pixels = 8;  // of the measuring detector, per side
    // The glare spread function (the header comment): at the positions on the axis (every
    // aperture), at every position or none; over a disc of spreadRadiusMm about the point's
    // image (0: the image height of the lens's largest field, at least 20 spot image radii),
    // on a coarse detector of spreadPixels per side.
    GlareSpreadAt spread = GlareSpreadAt::Axis;
    double spreadRadiusMm = 0.0;
    int spreadPixels = 128;
    RenderOptions render;  // raysPerPixel, photonsPerPass, seed, ...; splitBackward is set
    // When a run starts (pass 0) and after every pass: one task per run, "glare: position 2,
    // white field" (positions aperture-major; runs "black field", "white field", "point
    // source", "check, black field", ...), its passes counted.
    ProgressSink progress;
};

struct GlareValue {
    double value = 0.0, error = 0.0;  // 1 sigma
};

// The glare spread function at one position (the header comment).
struct GlareSpread {
    double radiusMm = 0.0;        // R: the disc about the point source's image
    double coreRadiusMm = 0.0;    // inside: the fine detector (3.8 spot image radii)
    std::vector<double> edgesMm;  // the annuli's edges, from 0 to R (log-spaced past the first)
    // Per annulus: irradiance over the disc's flux (1/mm^2), 1 sigma from the passes.
    std::vector<GlareValue> total, specular, diffuse;
    GlareValue discFlux;  // the flux the source brings to the disc (unit, source irradiance 1/mm^2)
    // The VGI recomputed from the GSF (isoplanatic): the disc's flux outside the spot image
    // radius over all of it, and its specular and diffuse parts.
    GlareValue vgi, vgiSpecular, vgiDiffuse;
    // On axis: theta_R, the bright field cone whose image the disc is, and the VGI rendered
    // for that field directly (the check). fieldDeg 0: not measured (off axis, or R beyond
    // the bright field or the lens's reach).
    double fieldDeg = 0.0;
    GlareValue directVgi, directSpecular, directDiffuse;
};

// One ghost's share of the VGI as the ghost analysis predicts it.
struct GlareGhost {
    std::string label;  // "L1.back > L1.front"
    double vgi = 0.0;
};

struct GlareField {
    double fNumber = 0.0;  // image-space F/# of the measurement (paraxial)
    Vec2 fieldDeg{0.0};
    Vec2 imageMm{0.0};  // the spot's image centre (real chief ray)
    double spotImageRadiusMm = 0.0;
    double measuredSideMm = 0.0;  // the square detector's side
    // Irradiance (unit/mm^2) over the measuring square.
    GlareValue black, blackSpecular, blackTir, blackBlur, blackDiffuse, white;
    // Their ratios to white: vgi = specular + blur + diffuse; tir is part of specular.
    GlareValue vgi, specular, tir, blur, diffuse;
    // The specular part predicted by the ghost analysis (analysis/ghosts/ghosts.h): every
    // two-reflection ghost walked backward from the spot's image centre through its path,
    // sequentially (GhostTracer::backwardIrradiance), over the rendered white irradiance;
    // and the image's irradiance it predicts for the bright field (the nominal path), over
    // the rendered one. Brightest ghosts first.
    double ghostPrediction = 0.0, imagePrediction = 0.0;
    std::vector<GlareGhost> ghosts;
    std::optional<GlareSpread> spread;  // with GlareSpec::spread
};

struct GlareResult {
    std::vector<GlareField> fields;
    std::string spectrum;  // how the field's spectrum is weighted
    std::string unit;      // "lm" or "W"
    double spotDiameterDeg = 0.0, fieldHalfAngleDeg = 0.0;
    int passes = 0;
    uint64_t raysPerPixel = 0, photonsPerPass = 0;
    double seconds = 0.0;

    // One row per position and aperture (analysis/reports/report_table.h): glare.csv, the
    // JSON's fields and the Markdown table; the GSF's annuli (gsf.csv) and its summary.
    ReportTable table() const;
    ReportTable spreadTable() const;
    ReportTable spreadSummaryTable() const;
    // The GSF against the distance from the image (gsf.png), and the VGI and its parts
    // against the spot's field angle, one line per aperture (glare.png, two positions or more).
    ChartSpec spreadChart() const;
    ChartSpec vgiChart() const;
    std::string markdown() const;
    std::string csv() const;
    std::string json() const;
    // The glare spread functions: a row per position and annulus (empty without them).
    std::string spreadCsv() const;
};

// The measurement's set-up around a scene (the header comment): the camera body, the field's
// window and the measuring detector; for runGlare and for tests that trace the same scenes.
class GlareBench {
  public:
    // ModelError for a lens that does not image from infinity or absurd spot and field sizes.
    GlareBench(const SceneSpec& scene, const GlassCatalog& catalog, const GlareSpec& spec);
    ~GlareBench();
    GlareBench(const GlareBench&) = delete;
    GlareBench& operator=(const GlareBench&) = delete;

    // The spot's image (centre, radius, the measuring square's side); ModelError naming the
    // position when the spot leaves the field or does not image.
    GlareField locate(Vec2 fieldDeg) const;
    // The scene of one measurement: the body, the field (with the black spot at f when
    // black; out to fieldHalfAngleDeg, 0: the spec's) and a square detector of side sideMm
    // centred on f's image.
    SceneSpec scene(const GlareField& f, bool black, double sideMm, int pixels,
                    double fieldHalfAngleDeg = 0.0) const;
    // The glare spread function's scene: a point source at infinity in f's direction (a
    // collimated beam over the port and 1 mm of the plate around it, irradiance 1/mm^2) and
    // square detectors centred on f's image, "gsf" of side 2 radiusMm and "gsf_core" of side
    // coreSideMm.
    SceneSpec spreadScene(const GlareField& f, double radiusMm, int pixels, double coreSideMm,
                          int corePixels) const;
    // The disc's radius R for f (GlareSpec::spreadRadiusMm or its default), and the angle of
    // the cone about the axis whose chief ray lands R from the axis (0: none within the
    // bright field).
    double spreadRadiusMm(const GlareField& f) const;
    double fieldAngleAtHeight(double heightMm) const;
    // The ghost analysis's irradiances at f's spot image centre (radiance 1 outside the
    // spot): the black field's through every two-reflection ghost, and the bright field's
    // through the nominal path. Fills f.ghosts (their irradiances, to be divided by white).
    // progress(done, total): the paths done, from the calling thread, every few paths.
    std::pair<double, double> ghostIrradiance(
        GlareField& f, const std::function<void(uint64_t, uint64_t)>& progress = {}) const;
    const std::string& spectrumText() const { return spectrumText_; }
    const std::string& unit() const { return unit_; }
    double radiusHintMm() const { return radiusHintMm_; }  // initial photon radius

  private:
    SceneSpec file_;  // with the body
    GlareSpec spec_;
    std::unique_ptr<RayAimer> aimer_;
    std::unique_ptr<SpectralSampler> spectrum_;
    std::string spectrumText_, unit_;
    double windowZMm_ = 0.0, windowRadiusMm_ = 0.0, radiusHintMm_ = 1.0;
    double portRadiusMm_ = 0.0, portFrontZMm_ = 0.0, portBackZMm_ = 0.0;
    // The lens for the ghost analysis (built once; the tracer needs a beam, which the
    // irradiances do not use).
    std::unique_ptr<PreparedScene> ghostScene_;
    std::unique_ptr<GhostTracer> ghostTracer_;
};

// ModelError for a spot or field that does not fit (the spot outside the bright field, a
// field direction the lens does not image), before the first render.
GlareResult runGlare(const SceneSpec& scene, const GlassCatalog& catalog, const GlareSpec& spec);

// Where an annulus [lo, hi) of the GSF is plotted: its geometric mean radius (the central
// disc, lo = 0: half its radius).
double spreadRadius(double lo, double hi);

// A ratio with its error from the errors of its terms (independent).
GlareValue ratio(const GlareValue& a, const GlareValue& b);

// glare.md, glare.csv, glare.json, gsf.csv and the charts (gsf and glare, SVG and PNG) into
// `dir` (created as needed); returns them in that order.
std::vector<std::filesystem::path> writeGlareFiles(const GlareResult& result,
                                                   const std::filesystem::path& dir);

}  // namespace veil
