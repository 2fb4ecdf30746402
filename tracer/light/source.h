#pragma once
// Light sources: where a ray starts, which way it goes, at which wavelength, and how much
// flux it carries.
//
// A closed set of kinds, dispatched with std::visit (no virtual calls):
//
//   collimated  a parallel beam from a field direction, filling the first lens surface
//   sun         the same beam with directions uniform over the solar disk (0.533 deg)
//   point       an isotropic point emitting into the cone that just covers the first surface
//   window      a disk in front of the lens, uniform radiance inside a cone about +z (the
//               seed paper's catadioptric case: 3.25 deg, 0.079833 lm)
//   lambertian  a disk or rectangle placed anywhere, cosine law (optionally within a cone)
//
// Frames and units: global coordinates of the sequential model (z along the optical axis,
// surface 1's vertex at z = 0), lengths in mm, angles in radians inside (degrees in files).
// Field directions follow the system fields: (x, y) degrees -> normalize(tan x, tan y, 1).
//
// Flux: every source has a total flux in W or lm (FluxUnit). emit() draws one ray for a run
// of rayCount rays and gives it flux totalFlux / rayCount times its spectral weight (1 when
// the spectral sampling matches the unit, the default), so the N rays of a run sum to the
// total flux. Beams (collimated, sun) start on a disk perpendicular to their direction,
// placed in front of everything in the lens, and wide enough that every point of the first
// surface out to its aperture (plus margin) is lit from every direction of the beam.
//
// Random numbers: emit() draws exactly kEmitUniforms numbers from the ray's stream, in this
// order: the wavelength, two for the position, two for the direction (beams without a
// direction spread draw and ignore them), so the draws that follow are the same for every
// kind.
//
// Evaluation (for the backward and bidirectional passes: next-event estimation toward a
// source, a backward ray that reaches one). Every kind emits from a surface S (a disk, a
// rectangle, or a point) into a set of directions, and emit() draws the ray's origin and
// direction independently of its line. With x the ray's origin, w its direction (global,
// unit) and theta the angle between w and the surface's normal:
//
//   kind        S and its normal           emitted(x, w)                 pdf(ray), measure
//   collimated  start disk, beam direction E = Phi / A   (unit/mm^2)     1 / A      per mm^2
//   sun         start disk, beam direction L = Phi / (A Omega cos th)    1 / (A Omega)
//                                                    (unit/(mm^2 sr))               per mm^2 sr
//   point       the point, cone axis       I = Phi / Omega   (unit/sr)   1 / Omega  per sr
//   window,     disk or rectangle, its +z  L = Phi / (A pi sin^2 c)      cos th / (A pi sin^2 c)
//   lambertian                                       (unit/(mm^2 sr))               per mm^2 sr
//
// (A the area of S, Omega the solid angle of the direction cone, c the emission cone's
// half-angle, Phi = totalFlux(); 0 outside the support.) Collimated and point sources are
// delta distributions: a beam's radiance is E delta(w - d) (a delta in direction; emitted()
// gives its weight, the irradiance on a plane perpendicular to the beam), a point's is
// I delta(x - p) (a delta in position; emitted() gives the intensity, as pbrt's PointLight::I).
// The sun draws directions uniform in solid angle over the solar disk with equal flux, so its
// radiance carries 1 / cos th (at most 1 + 1.1e-5 for 0.533 deg): it is exactly what emit()
// does. In every case Phi = integral over S and the directions of emitted(x, w) cos th
// (E A for a beam, I Omega for a point), and for every ray emit() produces
// emitted(x, w) cos th / pdf(ray) = Phi (cos th = 1 for the two delta kinds): the flux of an
// emitted ray (per ray of a run of one, before the spectral weight). Per line i, the
// radiance is share(i) times the total (emitted(x, w, i)) and the line is drawn with
// probability spectrum().probability(i), independent of the ray.
//
// The scene keys of [[source]] are documented in docs/format.md.

#include <array>
#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "geometry/frame.h"
#include "geometry/surface_shape.h"
#include "geometry/vec.h"
#include "tracer/light/spectrum.h"

namespace veil {

class TomlDocument;
class CounterRng;
class SequentialModel;

// Every length a [[source]] gives (positions, radii, sizes, margins, gaps, z) lies within
// +-kMaxSourceLengthMm (1000 km): anything farther is at infinity for a lens (a collimated or
// sun source), and rays starting beyond about 1e18 mm break Embree's single-precision
// traversal. Checked when the scene file is read, as a ParseError at the value.
inline constexpr double kMaxSourceLengthMm = 1e9;

// What the sources need to know about the lens: the first surface and its aperture, and how
// far forward (toward -z) the lens reaches.
struct EntranceAperture {
    int surface = 1;  // sequential surface index of the first surface
    std::string surfaceName;
    SurfaceShape shape;
    double vertexZMm = 0.0;
    double radiusMm = 0.0;       // mechanical semi-diameter if given, else clear; 0 = none
    double clearRadiusMm = 0.0;  // clear semi-diameter if given, else mechanical; 0 = none
    // The lowest z of any surface (1 to image) out to its semi-diameter (mechanical, else
    // clear; the vertex alone when it has none).
    double frontZMm = 0.0;

    // Lowest and highest z of the first surface over radial distances 0..rMm (sampled finely
    // enough for any even asphere; clamped to the shape's domain).
    std::pair<double, double> zRange(double rMm) const;
};
std::ostream& operator<<(std::ostream& os, const EntranceAperture& a);

EntranceAperture entranceAperture(const Prescription& p, const SequentialModel& model);

// The unit direction of a field angle pair (degrees), as for the system fields.
Vec3 fieldDirection(double xDeg, double yDeg);
// The one rule for a field angle pair of an object at infinity, as [[source]] field_deg reads
// it: both strictly between -90 and 90 degrees (at 90 the direction runs along the first
// surface, and the beam that fills the aperture carries unbounded flux). A ModelError naming
// `where` otherwise.
void checkFieldAngles(double xDeg, double yDeg, const std::string& where);

// Source Kinds

// A beam of parallel (collimated) or nearly parallel (sun) rays. Rays start uniformly on a
// disk perpendicular to `direction`, centred on `startCenterMm`.
struct Beam {
    Vec3 direction{0.0, 0.0, 1.0};  // central direction, unit, direction.z > 0
    Vec3 axisU{1.0, 0.0, 0.0};      // unit, perpendicular to direction
    Vec3 axisV{0.0, 1.0, 0.0};      // direction x axisU: (axisU, axisV, direction) right-handed
    Vec3 startCenterMm{0.0};
    double radiusMm = 0.0;          // start disk radius
    double apertureRadiusMm = 0.0;  // the aperture it fills, margin excluded
    double marginMm = 0.0;
    double halfAngleRad = 0.0;  // of the direction cone (0 = collimated)
    double areaMm2() const;     // of the start disk
};
std::ostream& operator<<(std::ostream& os, const Beam& b);

struct BeamOptions {
    double marginMm = 0.0;      // added to the aperture radius
    double radiusMm = 0.0;      // aperture radius to fill; 0 = the first surface's
    double startGapMm = 5.0;    // from the lens's front-most point to the nearest origin
    double halfAngleRad = 0.0;  // direction cone about the central direction
};
// The beam along `direction` that lights every point of the first surface out to
// radius + margin from every direction of its cone, starting startGapMm in front of the
// lens. Throws ModelError when there is no aperture to fill (no semi-diameter and no
// radiusMm), when the direction does not point toward +z, or when the cone reaches 90 deg
// from the axis.
Beam beamFillingAperture(const EntranceAperture& a, const Vec3& direction,
                         const BeamOptions& options);

struct CollimatedSource {
    Beam beam;
};
struct SunSource {
    Beam beam;  // beam.halfAngleRad is the solar radius, 0.2665 deg by default
};

// An isotropic point source emitting into a cone (uniform over its solid angle).
struct PointSource {
    Vec3 positionMm{0.0};
    Vec3 axis{0.0, 0.0, 1.0};  // unit
    Vec3 axisU{1.0, 0.0, 0.0};
    Vec3 axisV{0.0, 1.0, 0.0};
    double halfAngleRad = 0.0;    // up to pi (the whole sphere)
    double solidAngleSr() const;  // 2 pi (1 - cos halfAngle)
};
std::ostream& operator<<(std::ostream& os, const PointSource& s);

// The cone from `position` that just covers the first surface out to its aperture radius
// (or radiusMm when > 0) plus margin: axis and half-angle from the sampled surface, padded
// by the sampling error. Throws ModelError when the point is not in front of the surface.
PointSource pointSourceCoveringAperture(const EntranceAperture& a, const Vec3& positionMm,
                                        double marginMm, double radiusMm = 0.0);

// A flat emitting area: a disk or a rectangle in the xy plane of `frame`, emitting toward
// its +z with uniform radiance inside a cone of half-angle coneHalfAngleRad about +z
// (pi / 2: the Lambertian hemisphere). Directions follow the cosine law within the cone.
struct AreaEmitter {
    enum class Shape { Disk, Rectangle };
    Frame frame;  // global = frame(local); local z = the emitting normal
    Shape shape = Shape::Disk;
    double radiusMm = 0.0;  // Disk
    Vec2 sizeMm{0.0};       // Rectangle: full width along local x, height along local y
    double coneHalfAngleRad = 1.5707963267948966;
    // A black spot in the field: no light along directions within blackSpotHalfAngleRad of
    // the global unit direction blackSpotAxis (0: none). It takes nothing from the flux
    // bookkeeping: the radiance elsewhere stays flux / (area * projected solid angle of the
    // whole cone), and emit() gives the rays it draws into the spot no flux. (veil glare's
    // test field, ISO 9358's black area.)
    Vec3 blackSpotAxis{0.0, 0.0, 1.0};
    double blackSpotHalfAngleRad = 0.0;
    double areaMm2() const;
    // Projected solid angle of the cone, pi sin^2(cone): flux = radiance * area * this.
    double projectedSolidAngleSr() const;
    // Whether a global unit direction lies in the black spot.
    bool inBlackSpot(const Vec3& w) const;
};
std::ostream& operator<<(std::ostream& os, const AreaEmitter& e);

struct WindowSource {
    AreaEmitter area;  // a disk at z = const, normal +z
};
struct LambertianSource {
    AreaEmitter area;
};

using SourceShape =
    std::variant<CollimatedSource, SunSource, PointSource, WindowSource, LambertianSource>;
std::ostream& operator<<(std::ostream& os, const SourceShape& s);
const char* kindName(const SourceShape& s);  // "collimated", "sun", "point", ...

// Source Interface

struct EmittedRay {
    Ray ray;             // global, unit direction
    int wavelength = 0;  // index into the model's wavelengths
    double wavelengthNm = 0;
    double flux = 0;  // in the source's unit (W or lm)
};
std::ostream& operator<<(std::ostream& os, const EmittedRay& r);

class Source {
  public:
    // Uniforms emit() draws from the stream for every ray.
    static constexpr int kEmitUniforms = 5;

    Source(std::string name, SourceShape shape, double totalFlux, SpectralSampler spectrum,
           FileLoc loc = {});

    const std::string& name() const { return name_; }
    const SourceShape& shape() const { return shape_; }
    const char* kind() const { return kindName(shape_); }
    double totalFlux() const { return totalFlux_; }
    FluxUnit unit() const { return spectrum_.unit(); }
    const SpectralSampler& spectrum() const { return spectrum_; }
    const FileLoc& loc() const { return loc_; }  // where the scene file defines it

    // One ray of a run of rayCount rays (> 0): flux = totalFlux / rayCount * spectral weight.
    EmittedRay emit(CounterRng& rng, uint64_t rayCount) const;
    // The same from given uniforms in [0, 1): u[0] picks the line, u[1], u[2] the origin and
    // u[3], u[4] the direction (continuous maps, so evenly spread uniforms, such as
    // quasi-random points, give evenly spread rays).
    EmittedRay emit(const std::array<double, kEmitUniforms>& u, uint64_t rayCount) const;

    // Source Evaluation (measures and units in the header comment)
    // Which factor of the emitted radiance is a delta distribution.
    enum class Delta { None, Direction, Position };
    Delta delta() const;
    // Whether emit() can produce this ray: its origin lies on the emitting surface (within
    // 1e-9 of the source's size off its plane, 1e-12 relative past its rim) and its unit
    // direction lies in the emitted set (1e-9 rad for a beam's single direction).
    bool emits(const Ray& ray) const;
    // Radiance (unit/(mm^2 sr)) from the point along the direction, summed over the lines;
    // for a collimated beam the irradiance E (unit/mm^2), for a point the intensity I
    // (unit/sr). 0 when emits({pointMm, direction}) is false.
    double emitted(const Vec3& pointMm, const Vec3& direction) const;
    // The same for line i alone: share(i) * emitted(pointMm, direction).
    double emitted(const Vec3& pointMm, const Vec3& direction, int line) const;
    // Density with which emit() produces the ray (origin and direction; the line is drawn
    // independently), in the kind's measure; 0 when emits(ray) is false.
    double pdf(const Ray& ray) const;
    // Where a ray walking against the light (a backward ray) meets the emitting surface: the
    // distance t in (0, tMax] at which it crosses S with -ray.direction an emitted direction
    // there (emits({origin + t direction, -direction})). None for the delta kinds (collimated,
    // point: no backward ray meets them) and when it misses. The emitter is not an object of
    // the scene: it neither blocks nor reflects, as for the forward rays it starts.
    std::optional<double> crossing(const Ray& ray, double tMax) const;
    // Next-event estimation: light of line `line` arriving at pointMm straight from the
    // source (nothing in between is checked: the caller casts the shadow ray), sampled with
    // two uniforms. toSource is the unit direction from the point toward the source and
    // distanceMm the shadow ray's length (to the emitting surface; for a beam, to its start
    // disk). value is the arriving radiance divided by the pdf of toSource per steradian, so
    // bsdf * |cos| * value estimates the light scattered at the point (unit/mm^2):
    //   collimated  E, when the point lies downstream of the start disk and inside its rim
    //   sun         L Omega, the direction drawn uniformly over the solar disk
    //   point       I / d^2, inside the emission cone
    //   window,     L cos(theta_s) A / d^2, the point on S drawn uniformly
    //   lambertian
    // None when the sample carries nothing (outside the beam or cone, behind the emitter).
    // pdfSr is the density of toSource per steradian (0 for the delta kinds, collimated and
    // point), for weighing the sample against a BSDF-sampled direction (multiple importance
    // sampling).
    struct IncidentSample {
        Vec3 toSource{0.0};
        double distanceMm = 0.0;
        double value = 0.0;
        double pdfSr = 0.0;
    };
    std::optional<IncidentSample> sampleIncident(const Vec3& pointMm, int line, double u1,
                                                 double u2) const;
    // The density per steradian with which sampleIncident() draws the direction toSource from
    // pointMm, reaching the emitting surface at emitterPointMm (a point where it emits toward
    // pointMm, as crossing() finds): d^2 / (A cos theta_s) for the area kinds, 1 / Omega for
    // the sun, 0 for the delta kinds.
    double incidentPdf(const Vec3& pointMm, const Vec3& emitterPointMm, const Vec3& toSource) const;
    // Area of the emitting surface (mm^2; 0 for a point) and solid angle of its directions
    // (sr; 0 for a collimated beam).
    double emittingAreaMm2() const;
    double emittingSolidAngleSr() const;

  private:
    std::string name_;
    SourceShape shape_;
    double totalFlux_ = 0.0;
    SpectralSampler spectrum_;
    FileLoc loc_;
};
std::ostream& operator<<(std::ostream& os, const Source& s);
std::ostream& operator<<(std::ostream& os, Source::Delta d);  // "none", "direction", ...

// Reads every [[source]] table of the scene (none: an empty list). The wavelengths are the
// model's, weighted as in [system] (equal weights if the model was built at other
// wavelengths). Errors are ParseErrors at the key at fault (or the source's table, for
// problems of the whole source such as a first surface without a semi-diameter to fill);
// keys the reader does not use are left for TomlDocument::checkAllUsed().
std::vector<Source> readSources(TomlDocument& doc, const Prescription& p,
                                const SequentialModel& model);

}  // namespace veil
