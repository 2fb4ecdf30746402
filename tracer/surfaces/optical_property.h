#pragma once
// Surface optical properties: what happens to light that meets a surface.
//
// An OpticalProperty has a specular part and an optional scatter part. For one incident ray
// (a SurfaceContext) it splits the incident flux into four channels plus absorption:
//
//   specularReflect   mirror direction                    specularTransmit  Snell direction
//   scatterReflect    sampled, back into the incident medium
//   scatterTransmit   sampled, into the other medium
//   absorbed = 1 - (sum of the four)
//
// How the parts combine: the scatter model takes its fractions first (sR, sT); the specular
// model shares the rest, 1 - sR - sT, in the proportions it gives (r, t):
//   specularReflect = (1 - sR - sT) r,   specularTransmit = (1 - sR - sT) t.
// So a polished face with microroughness scatter loses to scatter what leaves the specular
// beam, a painted part (specular "absorber") reflects only its diffuse fraction, and the
// channels never add up to more than 1. They add up to exactly 1 (to rounding) when neither
// part absorbs.
//
// Specular models (r, t):
//   FresnelSpecular      uncoated: unpolarised Fresnel from n1 and n2, TIR -> (1, 0)
//   IdealArSpecular      (0, 1); TIR still reflects: (1, 0)
//   FixedSpecular        (R, T) whatever the angle (the seed's "1% specular reflectance" is
//                        R = 0.01, T = 0.99); under TIR the transmitted share reflects too:
//                        (R + T, 0), which is (1, 0) without absorption
//   QuarterWaveSpecular  one quarter-wave layer (index, design wavelength): thin-film
//                        interference for s and p at the ray's angle and wavelength,
//                        averaged (fresnel.h); TIR -> (1, 0)
//   MirrorSpecular       (R, 0), the rest absorbed
//   AbsorberSpecular     (0, 0)
// Channels::tir is set when the interface totally reflects and the specular model is one of
// the four dielectric ones (not for mirrors and absorbers, which transmit nothing anyway).
//
// Scatter models, each importance sampled exactly: a sampled direction has a pdf proportional
// to bsdf * cos(theta_out), so the weight of a scattered ray is the channel fraction itself,
// with no per-sample factor.
//   LambertianScatter  reflectance R and transmittance T: bsdf = R / pi in the incident
//                      hemisphere and T / pi in the other, sampled cosine-weighted.
//   GaussianScatter    reflectance, transmittance and a half-width w: a lobe about the
//                      specular direction (the mirror direction for reflection, the refracted
//                      one for transmission). Its intensity (flux per steradian) at angle a
//                      from that direction is proportional to exp(-kappa (1 - cos a)) with
//                      kappa = ln 2 / (1 - cos w): the intensity falls to half at a = w
//                      exactly, so w is the half width at half maximum (HWHM) of the angular
//                      distribution about the specular direction. For small w this is the
//                      Gaussian exp(-ln 2 (a / w)^2) (the von Mises-Fisher form is the
//                      Gaussian of the sphere, and it is sampled in closed form). Normalisation:
//                      the lobe carries exactly the channel fraction. Near grazing part of the
//                      lobe falls behind the surface (below the horizon); that part is cut off
//                      and the rest renormalised, so the channel still carries its full fraction
//                      (energy is conserved, the lobe is squeezed against the surface). Under
//                      TIR there is no refracted direction: the transmission lobe is off and
//                      its share goes to the specular part (the TIR reflection).
//   AbgScatter         Harvey's ABg model: bsdf = A / (B + |beta - beta0|^g), beta the
//                      projection of the outgoing direction on the surface plane and beta0
//                      that of the specular direction (direction cosines). Separate (A, B, g)
//                      for reflection (BRDF) and transmission (BTDF). The channel fraction is
//                      the total integrated scatter TIS(|beta0|) = integral of the bsdf over
//                      the unit disk of beta (= over the projected solid angle), which depends
//                      on the incidence angle; it is integrated numerically once per model on
//                      1025 incidence angles and interpolated (cubic): relative error < 1e-6 for
//                      lobes with B^(1/g) >= 1e-3, < 1e-5 down to B^(1/g) = 1e-4. Sampling
//                      inverts the radial CDF of r = |beta - beta0| (in closed form for g = 2,
//                      else by Newton on a tabulated exact integral, to 1e-14), draws the
//                      azimuth uniformly, and rejects points outside the unit disk (the
//                      horizon). Under TIR the transmission lobe is off as for the Gaussian.
//                      The lobe is general, A / (B + r^g)^p: p = 1 is ABg; g = 2 with
//                      p = -s / 2 is the Harvey-Shack model b0 (1 + (r / l)^2)^(s / 2)
//                      (harveyShack()), whose radial CDF is closed-form as well.
// Rejection (Gaussian and ABg near grazing) draws its further uniforms from a CounterRng keyed
// by the bits of (u1, u2): deterministic, and exact in distribution. At least half of a
// Gaussian lobe lies above the horizon, so it takes 2 tries on average at worst; after 256
// failed tries (probability < 1e-30) the specular direction is returned.
//
// Opaque parts (SurfaceContext::opaque: mechanics, meshes): nothing is transmitted. Both
// transmission channels are 0 and their share is absorbed; there is no TIR.
//
// Frames and units: all vectors are in one frame (global), unit length. The bsdf is per
// steradian and includes the channel fraction: bsdf(out) cos(theta_out) dw is the fraction of
// the incident flux scattered into dw. It is the "flux" BSDF: no n^2 radiance factors on
// transmission. It holds only the scatter part (the specular part is a delta).
//
// Transport modes (Veach's thesis, ch. 5: non-symmetric scattering and the adjoint BSDF, and
// ch. 6: generalised reciprocity; pbrt-v4's TransportMode, named here by what the path
// carries, see below). A pass walks a path either as light travels or against it, and the
// SurfaceContext always describes the walk: `direction` is the path's own incoming direction, `out`
// its outgoing one.
//   Flux        the path follows the light (forward photons from a source). bsdf(c, out,
//               Flux) is the flux BSDF above, f(d_in -> d_out), light going d_in -> d_out:
//               a photon's flux is multiplied by f cos(theta_out) / pdf(out), or by the
//               channel fraction for a specular child. Flux is conserved across a refracting
//               boundary, so there is no n^2 factor here.
//   Importance  the path runs against the light (backward rays from detector pixels): it
//               carries importance, and what it finally multiplies is radiance. bsdf(c, out,
//               Importance) is the adjoint BSDF f*(d_in -> d_out) = f(-d_out -> -d_in): the
//               flux BSDF of the light that arrives along -out and leaves along
//               -c.direction, evaluated in that light's own context (reverseContext()). A
//               backward path's weight is multiplied by f* cos(theta_out) / pdf(out).
// pbrt-v4 names the mode after the quantity the path computes: its Radiance mode is a path
// from the camera (our Importance), its Importance mode a path from a light (our Flux).
//
// Where the n^2 rule lives. Radiance is not invariant across a refracting boundary: light
// refracted from medium a into medium b has L_b = (n_b / n_a)^2 T L_a, because the projected
// solid angle shrinks by (n_a / n_b)^2 while the flux is kept. A backward path stepping from
// a (its incident medium, n1 of its context) into b (n2) meets light that goes b -> a, so its
// specular transmission weight is T (n1 / n2)^2 (specularTransmitWeight(c, Importance)); a
// forward photon's is T. For scatter the factor is not added by hand: the adjoint is
// evaluated by reversal, which is exact for any model. A physical BSDF obeys Veach's
// generalised reciprocity n_in^2 f(d_in -> d_out) = n_out^2 f(-d_out -> -d_in) (n_in the
// index on the side the light arrives from), so for it f* = (n1 / n2)^2 f in the path's
// context: the shortcut pbrt takes. The scatter models here are defined by how they split the
// incident flux and are not all reciprocal: Lambertian transmission has T / pi from both
// sides, and the Gaussian lobe (an intensity distribution renormalised per incidence angle)
// has f(d_in -> d_out) / f(-d_out -> -d_in) = cos(theta_in) M(theta_out) / (cos(theta_out)
// M(theta_in)), M the lobe's mass above the horizon, even in reflection. Lambertian and ABg
// reflection (A / (B + |beta - beta0|^g), symmetric in the two directions) are reciprocal;
// the ABg transmission lobe is not (beta0 carries n1 / n2). Evaluating the adjoint by reversal
// keeps the backward passes consistent with the forward photons whatever the model.

#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <variant>
#include <vector>

#include "geometry/vec.h"
#include "tracer/surfaces/k_correlation.h"
#include "tracer/surfaces/particulate.h"
#include "tracer/surfaces/tabulated_bsdf.h"

namespace veil {

// Optical Property Interface Types

struct SurfaceContext {
    Vec3 direction{0.0, 0.0, 1.0};  // incoming, unit
    Vec3 normal{0.0, 0.0, -1.0};    // unit, toward the side the ray comes from: dot(direction,
                                    // normal) < 0
    double n1 = 1.0;                // index of the incident medium (> 0)
    double n2 = 1.0;                // index of the other side (> 0); equal for opaque parts
    double wavelengthNm = 550.0;
    bool opaque = false;  // a mechanical part or mesh: the transmission channels are 0

    double cosIncidence() const;  // -dot(direction, normal), clamped to [0, 1]
};
std::ostream& operator<<(std::ostream& os, const SurfaceContext& c);

struct Channels {
    double specularReflect = 0.0;   // fractions of the incident flux
    double specularTransmit = 0.0;  // refraction (0 under TIR)
    double scatterReflect = 0.0;
    double scatterTransmit = 0.0;
    bool tir = false;  // the specular reflection is total internal reflection

    double sum() const {
        return specularReflect + specularTransmit + scatterReflect + scatterTransmit;
    }
    double absorbed() const { return 1.0 - sum(); }
};
std::ostream& operator<<(std::ostream& os, const Channels& c);

// Which way a pass walks a path (see the header comment).
enum class TransportMode { Flux, Importance };
std::ostream& operator<<(std::ostream& os, TransportMode m);  // "flux", "importance"

// The context of the light that a path walking against it meets: the light arrives along
// -out and leaves along -c.direction. Same normal and indices when out is on the incident
// side (reflection), flipped normal and swapped indices when it is across (transmission).
SurfaceContext reverseContext(const SurfaceContext& c, const Vec3& out);

struct ScatterSample {
    Vec3 direction{0.0};
    double pdf = 0.0;  // per steradian; 0 = no sample (the channel is empty)
};
std::ostream& operator<<(std::ostream& os, const ScatterSample& s);

// Specular Models

struct FresnelSpecular {};
struct IdealArSpecular {};
struct FixedSpecular {
    double reflectance = 0.01;
    double transmittance = 0.99;
};
struct QuarterWaveSpecular {
    double index = 1.38;  // layer index (MgF2)
    double designNm = 550.0;
};
struct MirrorSpecular {
    double reflectance = 1.0;
};
struct AbsorberSpecular {};

using SpecularModel = std::variant<FresnelSpecular, IdealArSpecular, FixedSpecular,
                                   QuarterWaveSpecular, MirrorSpecular, AbsorberSpecular>;
std::ostream& operator<<(std::ostream& os, const SpecularModel& m);

// Scatter Models

struct NoScatter {};

struct LambertianScatter {
    double reflectance = 0.0;
    double transmittance = 0.0;
};

class GaussianScatter {
  public:
    // halfWidthDeg in (0, 90]; fractions >= 0 with a sum <= 1 (throws std::invalid_argument).
    GaussianScatter(double reflectance, double transmittance, double halfWidthDeg);

    double reflectance() const { return reflectance_; }
    double transmittance() const { return transmittance_; }
    double halfWidthDeg() const { return halfWidthDeg_; }
    double kappa() const { return kappa_; }

    // The lobe about unit axis `axis` clipped to the hemisphere dot(w, side) > 0 (side unit,
    // dot(axis, side) >= 0). pdf per steradian of a direction, normalised over the hemisphere.
    double pdf(const Vec3& axis, const Vec3& side, const Vec3& w) const;
    // The unclipped lobe's mass in that hemisphere (in [1/2, 1]).
    double hemisphereMass(double cosAxisSide) const;
    ScatterSample sample(const Vec3& axis, const Vec3& side, double u1, double u2) const;

  private:
    double reflectance_, transmittance_, halfWidthDeg_;
    double kappa_;
    double norm_;  // 1 - exp(-2 kappa)
};

// bsdf = A / (B + r^g)^p: Harvey's ABg (p = 1), and with g = 2 the Harvey-Shack model
// b0 (1 + (r / l)^2)^(s / 2) (harveyShack(): A = b0 l^-s, B = l^2, p = -s / 2).
struct AbgParams {
    double a = 0.0;  // 1/sr
    double b = 1e-3;
    double g = 2.0;
    double p = 1.0;
};
// The Harvey-Shack lobe b0 (1 + (|beta - beta0| / l)^2)^(s / 2): b0 the BSDF at the specular
// direction (1/sr), l the shoulder (direction-cosine units), s the slope beyond it (<= 0).
AbgParams harveyShack(double b0, double l, double s);
std::ostream& operator<<(std::ostream& os, const AbgParams& p);

// One ABg lobe (BRDF or BTDF) with its radial CDF and TIS tables. Immutable; shared.
class AbgLobe {
  public:
    // a >= 0, b > 0, g >= 0, p >= 0 (throws std::invalid_argument).
    explicit AbgLobe(const AbgParams& p);

    const AbgParams& params() const { return p_; }
    double bsdf(double r) const;  // r = |beta - beta0|
    // TIS for |beta0| = b0 in [0, 1]: from the table, and by direct quadrature (slow; the
    // table's reference).
    double tis(double b0) const;
    double tisExact(double b0) const;
    double maxTis() const { return maxTis_; }
    // Point in the unit disk about beta0 with density proportional to bsdf (rejection).
    // Returns false after too many tries.
    bool sample(const Vec2& beta0, double u1, double u2, Vec2& beta) const;

    // The radial distribution r bsdf(r) on [0, 2] (unnormalised, without A and 2 pi).
    double radialCdf(double r) const;         // integral of r / (B + r^g)^p from 0 to r
    double inverseRadialCdf(double c) const;  // c in [0, radialCdf(2)]

  private:
    double radialDensity(double r) const;
    double partialIntegral(double r0, double r1) const;

    AbgParams p_;
    std::vector<double> knotR_, knotCdf_;  // radial CDF table (exact at the knots)
    double knot1_ = 0.0, logRatio_ = 0.0;  // geometric knots from knotR_[1]
    std::vector<double> tisTable_;         // TIS at incidence angles asin(b0) in [0, pi/2]
    double maxTis_ = 0.0;
};

// One or more lobes per side, summed: a fit with several terms (a narrow core and a wide
// skirt) is the sum of its lobes, sampled by choosing a lobe in proportion to its TIS at the
// incidence, with the pdf of the sum.
class AbgScatter {
  public:
    // At least one lobe; throws std::invalid_argument for bad parameters or when the lobes
    // can scatter more than all the light (the sum of their largest TIS > 1).
    AbgScatter(std::optional<AbgParams> brdf, std::optional<AbgParams> btdf);
    AbgScatter(const std::vector<AbgParams>& brdf, const std::vector<AbgParams>& btdf);

    // The first lobe of a side, or null.
    const AbgLobe* reflectLobe() const { return reflect_.empty() ? nullptr : reflect_[0].get(); }
    const AbgLobe* transmitLobe() const { return transmit_.empty() ? nullptr : transmit_[0].get(); }
    const std::vector<std::shared_ptr<const AbgLobe>>& lobes(bool transmit) const {
        return transmit ? transmit_ : reflect_;
    }
    bool has(bool transmit) const { return !lobes(transmit).empty(); }
    // Sums over a side's lobes, at |beta0| = b0 and r = |beta - beta0|.
    double tis(bool transmit, double b0) const;
    double bsdf(bool transmit, double r) const;
    // A point of the unit disk with density sum(bsdf) / sum(tis) (a lobe chosen by u1).
    bool sample(bool transmit, const Vec2& beta0, double u1, double u2, Vec2& beta) const;

  private:
    std::vector<std::shared_ptr<const AbgLobe>> reflect_, transmit_;
};

using ScatterModel = std::variant<NoScatter, LambertianScatter, GaussianScatter, AbgScatter,
                                  KCorrelationScatter, TabulatedScatter, ParticulateScatter>;
std::ostream& operator<<(std::ostream& os, const ScatterModel& m);

// Optical Property

class OpticalProperty {
  public:
    OpticalProperty() = default;
    // Checks the parameters (fractions in [0, 1] with sums <= 1, a positive coating index and
    // design wavelength): a ModelError naming the property otherwise.
    OpticalProperty(std::string name, SpecularModel specular, ScatterModel scatter = NoScatter{});

    // Built-ins.
    static OpticalProperty uncoated(std::string name = "uncoated");
    static OpticalProperty idealAr(std::string name = "ideal_ar");
    static OpticalProperty absorber(std::string name = "absorber");
    static OpticalProperty mirror(double reflectance = 1.0, std::string name = "mirror");

    const std::string& name() const { return name_; }
    const SpecularModel& specular() const { return specular_; }
    const ScatterModel& scatter() const { return scatter_; }
    bool hasScatter() const { return !std::holds_alternative<NoScatter>(scatter_); }

    Channels channels(const SurfaceContext& c) const;
    // A scattered direction for the reflect (transmit = false) or transmit channel, from two
    // uniforms in [0, 1). pdf = 0 when that channel is empty here.
    ScatterSample sampleScatter(const SurfaceContext& c, bool transmit, double u1, double u2) const;
    // pdf per steradian with which sampleScatter returns `out` (its side chooses the channel).
    double scatterPdf(const SurfaceContext& c, const Vec3& out) const;
    // Scatter bsdf per steradian including the channel fraction (see the header comment).
    double bsdf(const SurfaceContext& c, const Vec3& out) const;
    // The same for a path walked in `mode`: the flux BSDF (Flux) or its adjoint
    // (Importance), per steradian of `out`.
    double bsdf(const SurfaceContext& c, const Vec3& out, TransportMode mode) const;
    // The factor of a path's weight along the specular reflection and transmission of c:
    // Flux, the channel fractions; Importance, the light's channel fraction (its own
    // context, reverseContext()) and, for transmission, (n1 / n2)^2 (0 where c has no
    // refracted direction).
    double specularReflectWeight(const SurfaceContext& c, TransportMode mode) const;
    double specularTransmitWeight(const SurfaceContext& c, TransportMode mode) const;

  private:
    std::string name_;
    SpecularModel specular_ = FresnelSpecular{};
    ScatterModel scatter_ = NoScatter{};
};
std::ostream& operator<<(std::ostream& os, const OpticalProperty& p);

}  // namespace veil
