#include "tracer/surfaces/fresnel.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

namespace veil {

std::ostream& operator<<(std::ostream& os, const FresnelTerms& f) {
    os << "FresnelTerms{Rs " << f.rs << ", Rp " << f.rp << ", Ts " << f.ts << ", Tp " << f.tp;
    if (f.tir) os << ", TIR";
    return os << "}";
}

namespace {

double clampCos(double c) { return std::clamp(c, 0.0, 1.0); }

// sin^2 of the angle in a medium of index n, by Snell's law from medium 1. Written exactly as
// refract() (sequential_trace.h) writes it, so both agree on TIR to the last bit.
double sin2In(double n1, double n, double cos1) {
    const double mu = n1 / n;
    return mu * mu * std::max(0.0, 1.0 - cos1 * cos1);
}

FresnelTerms totalReflection(bool tir) {
    FresnelTerms f;
    f.rs = f.rp = 1.0;
    f.tir = tir;
    return f;
}

}  // namespace

bool totalInternalReflection(double n1, double n2, double cosIncidence) {
    return n1 > n2 && sin2In(n1, n2, clampCos(cosIncidence)) > 1.0;
}

// Fresnel Bare Interface

FresnelTerms fresnelDielectric(double n1, double n2, double cosIncidence) {
    const double ci = clampCos(cosIncidence);
    FresnelTerms f;
    if (n1 == n2) {  // no interface
        f.ts = f.tp = 1.0;
        return f;
    }
    const double sin2t = sin2In(n1, n2, ci);
    if (sin2t > 1.0) return totalReflection(true);
    const double ct = std::sqrt(1.0 - sin2t);
    // Amplitude reflection coefficients; the energy transmittances are written out so they
    // do not lean on R + T = 1.
    const double sDen = n1 * ci + n2 * ct;
    const double pDen = n2 * ci + n1 * ct;
    const double rs = (n1 * ci - n2 * ct) / sDen;
    const double rp = (n2 * ci - n1 * ct) / pDen;
    const double fourN1N2 = 4.0 * n1 * ci * n2 * ct;
    f.rs = rs * rs;
    f.rp = rp * rp;
    f.ts = fourN1N2 / (sDen * sDen);
    f.tp = fourN1N2 / (pDen * pDen);
    return f;
}

double fresnelReflectance(double n1, double n2, double cosIncidence) {
    return fresnelDielectric(n1, n2, cosIncidence).reflectance();
}

// Fresnel Thin Film

FresnelTerms thinFilm(double n1, double nc, double thicknessNm, double n2, double cosIncidence,
                      double wavelengthNm) {
    using Complex = std::complex<double>;
    const double c1 = clampCos(cosIncidence);
    if (totalInternalReflection(n1, n2, c1)) return totalReflection(true);
    if (c1 == 0.0) return totalReflection(false);  // grazing: nothing enters

    // Cosines in the layer and the exit medium; an imaginary cosine (principal root, Im >= 0)
    // is an evanescent wave that decays with e^{i beta}.
    auto cosIn = [&](double n) { return std::sqrt(Complex(1.0 - sin2In(n1, n, c1), 0.0)); };
    const Complex cc = cosIn(nc);
    const double c2 = std::sqrt(std::max(0.0, 1.0 - sin2In(n1, n2, c1)));

    const Complex beta = 2.0 * std::numbers::pi * nc * thicknessNm * cc / wavelengthNm;
    const Complex phase = std::exp(Complex(0.0, 1.0) * beta);
    const Complex phase2 = phase * phase;
    const double flux = (n2 * c2) / (n1 * c1);  // transmitted / incident power per |t|^2

    auto airy = [&](Complex r1c, Complex rc2, Complex t1c, Complex tc2, double& reflect,
                    double& transmit) {
        const Complex den = 1.0 + r1c * rc2 * phase2;
        reflect = std::norm((r1c + rc2 * phase2) / den);
        transmit = flux * std::norm(t1c * tc2 * phase / den);
    };

    FresnelTerms f;
    {  // s: amplitude coefficients with the admittances n cos
        const Complex a1 = n1 * c1, ac = nc * cc, a2 = n2 * c2;
        airy((a1 - ac) / (a1 + ac), (ac - a2) / (ac + a2), 2.0 * a1 / (a1 + ac),
             2.0 * ac / (ac + a2), f.rs, f.ts);
    }
    {  // p: E-field amplitude coefficients
        const Complex n1cc = n1 * cc, ncc1 = nc * c1, n2cc = n2 * cc, ncc2 = nc * c2;
        airy((ncc1 - n1cc) / (ncc1 + n1cc), (n2cc - ncc2) / (n2cc + ncc2),
             2.0 * n1 * c1 / (ncc1 + n1cc), 2.0 * nc * cc / (n2cc + ncc2), f.rp, f.tp);
    }
    return f;
}

FresnelTerms quarterWaveCoating(double n1, double nc, double designNm, double n2,
                                double cosIncidence, double wavelengthNm) {
    return thinFilm(n1, nc, designNm / (4.0 * nc), n2, cosIncidence, wavelengthNm);
}

}  // namespace veil
