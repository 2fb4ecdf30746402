#pragma once
// The sequential ghost estimate: every ghost path of a lens traced unfolded, on a grid of
// real rays, and ranked.
//
//   SceneGeometry + SceneTransport ──GhostTracer──> per ghost, per source: flux, focus, footprint,
//                                             peak irradiance (deterministic, fast)
//
// The paths and their criteria: ghost_paths.h. The Monte Carlo check of the same paths:
// ghost_monte_carlo.h.
//
// Sequential estimate. The unfolded path is traced with the exact surfaces (the same shapes
// as the scene), real rays on a square grid over each source's beam (or its cone, for point
// sources) at every source wavelength. At every surface the ray is clipped where the scene's
// exact face ends (lens faces: the face radius of lens_solid.h; mirrors: clear aperture and
// hole; the stop: its clear semi-diameter when the scene has a stop plate), and its flux is
// multiplied by the channel of the face's optical property (specular transmittance,
// specular reflectance at a ghost reflection or a mirror) at its own angle of incidence and
// wavelength, and by the internal transmittance of each glass it crosses. So the estimate is
// the expectation of the Monte Carlo value under the same model: unpolarised Fresnel per
// event, catalog absorption, coatings as assigned. It differs by the quadrature error of the
// grid (gridRays across the beam), by the solar disk (a sun is traced at its central
// direction) and by whatever non-sequential parts (mechanics, meshes) the sequential path
// ignores.
//
// Per ghost and source it reports: the flux on the detector and its ratio to the nominal
// image's; the paraxial ghost focus relative to the detector along the axis (the y-nu trace
// of the unfolded path from the source's conjugate); the footprint diameter on the detector
// (twice the largest distance of a ray from the flux centroid); the peak irradiance (flux per
// area in square bins of max(pixel pitch, footprint / 16) centred on the centroid) and its
// ratio to the nominal image's peak, binned the same way; flags for a ghost that focuses near
// the detector (footprint below nearFocusMm) and one that focuses inside glass (a paraxial
// real focus within a glass gap of the unfolded path: the laser damage risk).
// Ranking: by the peak irradiance over all sources, brightest first.

#include <atomic>
#include <functional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "analysis/ghosts/ghost_paths.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

struct DetectorGeometry;
struct SceneGeometry;
struct SceneTransport;

struct GhostOptions {
    int order = 2;                            // 2, or 4 (two- and four-reflection ghosts)
    int gridRays = 64;                        // grid points across a beam's diameter
    double minFourthOrderReflectance = 1e-7;  // product of four normal-incidence reflectances
    double nearFocusMm = 0.0;                 // footprint below this: near focus; 0 = 10 pixels
    std::string detector;                     // detector name; empty = the first detector
};
std::ostream& operator<<(std::ostream& os, const GhostOptions& o);

// What one ghost (or the nominal path) does for one source.
struct GhostSourceResult {
    std::string source;
    double flux = 0.0;          // on the detector, in the source's unit
    double relativeFlux = 0.0;  // flux / the nominal image's flux for this source
    // Paraxial focus minus the detector position along the axis (mm, + = behind the
    // detector); infinite when the ghost leaves collimated.
    double focusMm = 0.0;
    double footprintMm = 0.0;         // diameter on the detector
    Vec2 centroidMm{0.0};             // detector local x, y
    double peakIrradiance = 0.0;      // unit / mm^2
    double relativeIrradiance = 0.0;  // / the nominal image's peak irradiance
    bool nearFocus = false;
    std::string glassFocus;  // where a paraxial focus lies inside glass ("" = none)
    int raysTraced = 0;      // grid rays (all wavelengths)
    int raysArrived = 0;     // of those, on the detector
};
std::ostream& operator<<(std::ostream& os, const GhostSourceResult& r);

struct GhostEstimate {
    GhostPath path;
    std::vector<GhostSourceResult> sources;  // in the scene's source order
    double flux() const;                     // summed over sources
    double relativeFlux() const;             // flux() / nominal flux summed over sources
    double peakIrradiance() const;           // largest over sources
    double relativeIrradiance() const;       // largest over sources
    bool nearFocus() const;
    std::string glassFocus() const;  // the first source's glass focus, if any
    double nominalFlux = 0.0;        // summed over sources (for relativeFlux)
};

struct GhostAnalysis {
    std::vector<int> surfaces;  // ghost surfaces (sequential indices)
    std::vector<std::string> surfaceNames;
    std::string detector;               // its name
    GhostEstimate nominal;              // the nominal image through the same machinery
    std::string allGhostsCriterion;     // every enumerated ghost together
    std::vector<GhostEstimate> ghosts;  // ranked: brightest peak irradiance first
    int pruned = 0;                     // four-reflection paths left out by the energy bound
    double seconds = 0.0;               // time of the sequential estimate
    uint64_t raySurfaceSteps = 0;       // surface intersections attempted (image included)
};

// Unfolded-path sequential tracer over a built scene (the setups must outlive it).
class GhostTracer {
  public:
    // Throws ModelError for a source kind without a sequential model (window, lambertian) and
    // for an unknown detector name.
    GhostTracer(const SceneGeometry& geometry, const SceneTransport& transport,
                const GlassCatalog& catalog, const GhostOptions& options = {});

    const SequentialModel& model() const { return model_; }
    const DetectorGeometry& detector() const { return *detector_; }
    int detectorIndex() const { return detectorIndex_; }

    // Every ghost path of the options' order, with names and criteria; `pruned` counts the
    // four-reflection paths below the energy bound.
    std::vector<GhostPath> enumerate(int* pruned = nullptr) const;
    // The path with no reflection (the nominal image).
    GhostPath nominalPath() const;
    // Mirror reflections along a path (0 for a lens without mirrors).
    int mirrorReflections(const GhostPath& path) const;
    // The sequential estimate of one path (nominal: reflections empty) for every source.
    // `nominal` (may be null) gives the ratios.
    GhostEstimate estimate(const GhostPath& path, const GhostEstimate* nominal) const;
    // The same for many two-reflection paths at once, sharing the traced beginnings (the
    // forward path to the first reflection, the backward path to the second): the same
    // numbers as estimate() path by path, with about 2.4 times fewer surface steps for a
    // 12-surface lens.
    std::vector<GhostEstimate> estimatePairs(const std::vector<GhostPath>& paths,
                                             const GhostEstimate* nominal) const;
    // All of it: enumerate, estimate, rank.
    GhostAnalysis analyse() const;

    // Rays of one path, source and wavelength on the detector (local x, y and flux), for tests
    // and images.
    struct DetectorRay {
        Vec2 xyMm{0.0};
        double flux = 0.0;
    };
    std::vector<DetectorRay> traceGrid(const GhostPath& path, int source, int wavelength,
                                       int* traced = nullptr) const;
    // The light a path brings to one point of the image from an extended source, walked
    // backward (reciprocity): rays from the point (image surface local x, y) on a grid of
    // gridSide^2 over the last surface's aperture, through the path's steps in reverse, each
    // weighted by its projected solid angle at the point and by the same channels as forward;
    // `radiance` gives the source's radiance (per unit) along a light direction leaving object
    // space toward the lens (global, unit; 0 where nothing shines). The result is the
    // irradiance at the point (radiance unit times sr) at model wavelength w.
    double backwardIrradiance(const GhostPath& path, Vec2 imagePointMm, int w,
                              const std::function<double(const Vec3&)>& radiance,
                              int gridSide = 256) const;
    // The grid rays of one source as launched (ray, model wavelength index), for baselines.
    std::vector<std::pair<Ray, int>> gridRays(int source) const;
    // The paraxial focus relative to the detector (see GhostSourceResult::focusMm) and the
    // glass-focus note for one path and source.
    std::pair<double, std::string> paraxialFocus(const GhostPath& path, int source) const;

  private:
    struct Step {
        int surface = 0;
        int gapBefore = 0, gapAfter = 0;
        bool forwardBefore = true, forwardAfter = true;
        bool reflect = false;  // the ray reflects here (ghost reflection or a mirror)
    };
    std::vector<Step> steps(const GhostPath& path) const;
    struct RayState {
        Vec3 pos{0.0}, dir{0.0, 0.0, 1.0};
        double flux = 0.0;
        int at = 0;  // the surface the ray is on (0: none yet)
    };
    // Whether a mirror out of sequence blocks the segment from r.pos to distance t (toward
    // surface `target`): a Cassegrain's secondary shading the primary, for example.
    bool obscured(const RayState& r, double t, int target) const;
    // Share of the source's flux at model wavelength w.
    double lineShare(int source, int w) const;
    // Grid ray (ix, iy) of a source at wavelength w; false outside the disk.
    bool launch(int source, int w, int ix, int iy, RayState& r) const;
    // One step: meet the surface, clip, weight by the property's channel, turn. False = lost.
    bool advance(RayState& r, const Step& step, int w) const;
    // From after the last surface to the detector; false when it misses.
    bool land(const RayState& r, int w, DetectorRay& out) const;
    GhostSourceResult summarise(const GhostPath& path, int source,
                                const std::vector<DetectorRay>& rays, int raysTraced,
                                const GhostEstimate* nominal) const;

    const SceneGeometry* setup_;
    const SceneTransport* trace_;
    SequentialModel model_;
    GhostOptions options_;
    const DetectorGeometry* detector_ = nullptr;
    int detectorIndex_ = 0;
    std::vector<int> ghostSurfaces_;
    // Surface intersections attempted so far (all threads; for benchmarks and reports).
    mutable std::atomic<uint64_t> steps_{0};
    std::vector<double> clipRadius_;  // per sequential surface; infinity = no clip
    std::vector<double> holeRadius_;  // per sequential surface
    std::vector<int> mirrors_;        // mirror surfaces (obscure segments out of sequence)
    std::vector<std::vector<double>> cellFlux_;  // [source][wavelength]: one grid cell's flux
    std::string firstFace_;  // first lens face when surfaces come before it, else ""

    std::vector<int> propertyOf_;          // per sequential surface: index into properties, -1
    std::vector<int> mediumOfGap_;         // per gap: scene medium id
    std::vector<std::string> objectName_;  // per sequential surface ("" = no object)
};

}  // namespace veil
