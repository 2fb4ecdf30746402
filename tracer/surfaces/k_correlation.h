#pragma once
// Scatter from surface roughness: the K-correlation (ABC) power spectral density in the
// Rayleigh-Rice (smooth-surface, first-order vector perturbation) BSDF.
//
// The surface's isotropic two-dimensional PSD of height, at spatial frequency f (1/um):
//
//     PSD(f) = A / (1 + (B f)^2)^(C / 2)        A in nm^2 um^2, B in um (the correlation
//                                                length), C > 0 (the slope: PSD ~ f^-C)
//
// and its RMS roughness over all frequencies (C > 2): sigma^2 = 2 pi A / (B^2 (C - 2)).
// The light scatters from the frequencies it can see: a direction beta (its projection on
// the surface plane, a point of the unit disk) takes the frequency f = |beta - beta0| / lambda,
// lambda the wavelength in the incident medium (reflection) or n2 |beta - beta0| / lambda0
// (transmission into index n2; beta0 the specular direction's projection on its side).
//
//   BRDF = (16 pi^2 / lambda^4) cos(i) cos(s) Q PSD(f)              Rayleigh-Rice, with
//          the polarisation factor Q taken as the surface's reflectance R, a constant (the
//          usual approximation for unpolarised light and scatter not far from specular:
//          Stover, Optical Scattering, 3rd ed., SPIE 2012, ch. 5);
//   BTDF = (4 pi^2 n2^2 / lambda0^4) (n1 cos(i) - n2 cos(t))^2 PSD(f) the scalar phase
//          perturbation of the refracted wave, its obliquity taken at the refracted direction t.
//
// Integrated over the hemisphere (TIS) in the smooth limit (B >> lambda, all the PSD at
// frequencies that propagate) they give the textbook totals
//   TIS_R = R (4 pi sigma cos(i) / lambda)^2,  TIS_T = (2 pi sigma (n1 cos(i) - n2 cos(t)) /
//   lambda0)^2.
// In direction cosines the lobe is a Harvey-Shack lobe: with l = lambda / B,
// PSD(|beta - beta0| / lambda) = A (1 + (r / l)^2)^(-C / 2), r = |beta - beta0|; so the
// K-correlation BRDF is Harvey-Shack's b0 = 16 pi^2 cos^2(i) R A / lambda^4, l = lambda / B,
// s = -C near the specular direction, times cos(s) / cos(i) away from it.
//
// The TIS of each lobe comes from a table over incidence and l (built once per model: l
// changes with wavelength and index), cubic in both; directions are sampled from the
// Harvey-Shack lobe exactly (closed-form inverse of its radial CDF) and, for the BRDF,
// accepted with probability cos(s), so the sampled density is exactly BSDF cos(s) / TIS.

#include <memory>
#include <optional>
#include <ostream>
#include <vector>

#include "geometry/vec.h"

namespace veil {

struct KCorrelationParams {
    double aNm2Um2 = 0.0;       // A >= 0
    double bUm = 1.0;           // B > 0
    double c = 3.0;             // C > 0
    double reflectance = 0.0;   // Q of the BRDF, 0 to 1 (0: no BRDF)
    bool transmission = false;  // a BTDF on transparent surfaces
};
std::ostream& operator<<(std::ostream& os, const KCorrelationParams& p);

// A from the RMS roughness over all frequencies (C > 2): A = sigma^2 B^2 (C - 2) / (2 pi).
double kCorrelationA(double sigmaNm, double bUm, double c);

// The incidence-dependent part of one lobe: BSDF = scale (1 + (r / l)^2)^(-C / 2), times
// cos(s) for the BRDF.
struct KcLobe {
    double scale = 0.0;  // 1/sr
    double l = 1.0;      // direction-cosine units
    double b0 = 0.0;     // |beta0|, in [0, 1]
    bool cosWeighted = false;
};
std::ostream& operator<<(std::ostream& os, const KcLobe& l);

class KCorrelationScatter {
  public:
    // A >= 0, B > 0, C > 0, reflectance in [0, 1], and a BRDF or a BTDF (throws
    // std::invalid_argument).
    explicit KCorrelationScatter(const KCorrelationParams& p);

    const KCorrelationParams& params() const { return p_; }
    bool reflects() const { return p_.reflectance > 0.0 && p_.aNm2Um2 > 0.0; }
    bool transmits() const { return p_.transmission && p_.aNm2Um2 > 0.0; }

    // The PSD (nm^2 um^2) at f (1/um), and the RMS roughness (nm) of the frequencies in
    // [f0, f1] (f1 may be infinite when C > 2).
    double psd(double fPerUm) const;
    double bandSigmaNm(double f0PerUm, double f1PerUm) const;

    // The lobe for a ray of vacuum wavelength wavelengthNm meeting the surface from index n1
    // with cos(i) = cosI; for the BTDF, n2 and cosT = cos(t) of the refracted direction.
    KcLobe reflectLobe(double wavelengthNm, double n1, double cosI) const;
    KcLobe transmitLobe(double wavelengthNm, double n1, double n2, double cosI, double cosT) const;

    // BSDF (1/sr) at r = |beta - beta0| with cos(s) = cosOut.
    double bsdf(const KcLobe& lobe, double r, double cosOut) const;
    // Integral of BSDF cos(s) over the hemisphere: from the table, and by direct quadrature
    // of higher order than the table's (slow; the table's reference).
    double tis(const KcLobe& lobe) const;
    double tisExact(const KcLobe& lobe) const;
    // A point of the unit disk with density BSDF / TIS in beta (rejection); beta0 with
    // |beta0| = lobe.b0. False after too many tries.
    bool sample(const KcLobe& lobe, const Vec2& beta0, double u1, double u2, Vec2& beta) const;

  private:
    struct Table;
    // (1 / l^2) times the integral over the unit disk of (1 + (r / l)^2)^(-C / 2), times
    // sqrt(1 - |beta|^2) if cosWeighted; fine: the reference's higher-order quadrature.
    double shapeIntegral(double b0, double l, bool cosWeighted, bool fine = false) const;
    double shapeFromTable(const Table& t, double b0, double l, bool cosWeighted) const;

    KCorrelationParams p_;
    std::shared_ptr<const Table> reflectTable_, transmitTable_;
};

}  // namespace veil
