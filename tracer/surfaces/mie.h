#pragma once
// Light scattering by a homogeneous sphere (Mie theory), for particulate contamination.
//
// A sphere of diameter D and complex refractive index m (relative to the medium; m = n + i k,
// k >= 0 absorbing) in light of wavelength lambda (in the medium) has the size parameter
// x = pi D / lambda. Its scattering coefficients a_n, b_n (n = 1 .. x + 4 x^(1/3) + 2) follow
// from the Riccati-Bessel functions psi_n(x) = x j_n(x), xi_n(x) = x h_n^(1)(x), taken by
// upward recurrence, and the logarithmic derivative D_n(mx) = psi_n'(mx) / psi_n(mx), taken by
// downward recurrence from well above the last order (stable for any m and x): Bohren and
// Huffman, "Absorption and Scattering of Light by Small Particles" (Wiley 1983), ch. 4 and
// appendix A:
//
//   a_n = ((D_n / m + n / x) psi_n - psi_{n-1}) / ((D_n / m + n / x) xi_n - xi_{n-1})
//   b_n = ((m D_n + n / x) psi_n - psi_{n-1}) / ((m D_n + n / x) xi_n - xi_{n-1})
//   Q_sca = 2 / x^2 sum (2n + 1) (|a_n|^2 + |b_n|^2),  Q_ext = 2 / x^2 sum (2n + 1) Re(a_n + b_n)
//   S_1(mu) = sum (2n + 1) / (n (n + 1)) (a_n pi_n + b_n tau_n),  S_2 with pi_n, tau_n swapped
//
// (pi_n, tau_n the angular functions of mu = cos(scattering angle)). Unpolarised light
// scatters into the solid angle dOmega at the scattering angle theta the share
//
//   p(mu) = (|S_1|^2 + |S_2|^2) / (2 pi x^2 Q_sca)     (integral over the sphere = 1)
//
// of what the sphere scatters; its cross sections are Q times pi D^2 / 4.

#include <complex>
#include <vector>

namespace veil {

struct MieEfficiencies {
    double qext = 0.0, qsca = 0.0;
    double qback = 0.0;      // backscatter efficiency |sum (2n + 1)(-1)^n (a_n - b_n)|^2 / x^2
    double asymmetry = 0.0;  // g = <cos theta>
    double qabs() const { return qext - qsca; }
};

// The efficiencies of a sphere of size parameter x > 0 and relative index m (imag(m) >= 0),
// and, when intensity is given, (|S_1|^2 + |S_2|^2) / 2 at each mu of `mu` (written to
// intensity, resized). Throws std::invalid_argument for x <= 0, x > 1e5 or real(m) <= 0.
MieEfficiencies mieScatter(double x, std::complex<double> m, const std::vector<double>& mu = {},
                           std::vector<double>* intensity = nullptr);

}  // namespace veil
