#pragma once
// Fresnel reflectance and transmittance of dielectric interfaces, bare and with a single
// thin-film layer (the quarter-wave antireflection coating).
//
// Everything here is in power (intensity) terms, not amplitudes, for light arriving from
// the medium of index n1 at an interface with the medium of index n2 (both real, > 0),
// cosIncidence = cos of the angle of incidence in medium 1, in [0, 1]. s is the
// polarisation perpendicular to the plane of incidence (TE), p the one in it (TM);
// unpolarised light is their mean. The transmittances are energy fractions
// (n2 cos t / n1 cos i |t|^2), so R + T = 1 for every lossless case; the two are computed
// from separate formulas, which the tests use as a check.
//
// Total internal reflection: for n1 sin(i) > n2 the reflectance is exactly 1 and the
// transmittance exactly 0, and the result carries tir = true. At the critical angle itself
// both branches agree (Rs = Rp = 1), so R is continuous there.
//
// Thin film: one homogeneous layer of index nc and physical thickness d between media 1 and
// 2, summed over all internal reflections (the Airy formula):
//
//   r = (r1c + rc2 e^{2i beta}) / (1 + r1c rc2 e^{2i beta}),  beta = 2 pi nc d cos(c) / lambda
//
// for s and p separately with the amplitude coefficients of each interface, cos(c) the
// (possibly imaginary, for an evanescent layer) cosine of the angle in the layer, lambda the
// vacuum wavelength (indices are relative to air, so wavelengths in air serve equally).
// A quarter-wave layer has nc d = designNm / 4; at the design wavelength and normal
// incidence R = ((n1 n2 - nc^2) / (n1 n2 + nc^2))^2, zero for nc = sqrt(n1 n2).

#include <ostream>

namespace veil {

struct FresnelTerms {
    double rs = 0.0;  // reflectance, s polarisation
    double rp = 0.0;  // reflectance, p polarisation
    double ts = 0.0;  // transmittance, s
    double tp = 0.0;  // transmittance, p
    bool tir = false;

    double reflectance() const { return 0.5 * (rs + rp); }    // unpolarised
    double transmittance() const { return 0.5 * (ts + tp); }  // unpolarised
};
std::ostream& operator<<(std::ostream& os, const FresnelTerms& f);

// Whether light from n1 at this incidence is totally reflected (n1 sin(i) > n2).
bool totalInternalReflection(double n1, double n2, double cosIncidence);

// A bare interface.
FresnelTerms fresnelDielectric(double n1, double n2, double cosIncidence);
// Unpolarised reflectance of a bare interface: fresnelDielectric(...).reflectance().
double fresnelReflectance(double n1, double n2, double cosIncidence);

// One layer of index nc and physical thickness thicknessNm (nm) between n1 and n2.
FresnelTerms thinFilm(double n1, double nc, double thicknessNm, double n2, double cosIncidence,
                      double wavelengthNm);
// The quarter-wave layer for designNm (thickness designNm / (4 nc)).
FresnelTerms quarterWaveCoating(double n1, double nc, double designNm, double n2,
                                double cosIncidence, double wavelengthNm);

}  // namespace veil
