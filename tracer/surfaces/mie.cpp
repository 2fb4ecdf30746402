#include "tracer/surfaces/mie.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace veil {

MieEfficiencies mieScatter(double x, std::complex<double> m, const std::vector<double>& mu,
                           std::vector<double>* intensity) {
    using C = std::complex<double>;
    if (!(x > 0.0) || !(x <= 1e5))
        throw std::invalid_argument("Mie size parameter must be in (0, 1e5] (got " +
                                    std::to_string(x) + ")");
    if (!(m.real() > 0.0) || m.imag() < 0.0)
        throw std::invalid_argument("Mie refractive index needs real part > 0, imaginary >= 0");
    const int nStop = static_cast<int>(std::ceil(x + 4.0 * std::cbrt(x) + 2.0));
    const C mx = m * x;
    const int nStart = static_cast<int>(std::ceil(std::max<double>(nStop, std::abs(mx)))) + 16;

    // D_n(mx), n = 0 .. nStart, by downward recurrence from D_nStart = 0.
    std::vector<C> d(static_cast<size_t>(nStart) + 1, C(0.0));
    for (int n = nStart; n > 0; --n) {
        const C nOverMx = static_cast<double>(n) / mx;
        d[static_cast<size_t>(n) - 1] = nOverMx - 1.0 / (d[static_cast<size_t>(n)] + nOverMx);
    }

    // Riccati-Bessel functions by upward recurrence: psi_{-1} = cos x, psi_0 = sin x,
    // chi_{-1} = -sin x, chi_0 = cos x; xi_n = psi_n - i chi_n.
    double psi0 = std::cos(x), psi1 = std::sin(x);
    double chi0 = -std::sin(x), chi1 = std::cos(x);
    C xi1(psi1, -chi1);

    const size_t angles = mu.size();
    std::vector<C> s1(angles, C(0.0)), s2(angles, C(0.0));
    std::vector<double> piPrev(angles, 0.0), piCur(angles, 1.0);  // pi_0 = 0, pi_1 = 1

    MieEfficiencies e;
    double qsca = 0.0, qext = 0.0, g = 0.0;
    C back(0.0), aPrev(0.0), bPrev(0.0);
    for (int n = 1; n <= nStop; ++n) {
        const double dn = n;
        const double psi = (2.0 * dn - 1.0) * psi1 / x - psi0;
        const double chi = (2.0 * dn - 1.0) * chi1 / x - chi0;
        const C xi(psi, -chi);
        const C dnm = d[static_cast<size_t>(n)];
        const C ta = dnm / m + dn / x, tb = m * dnm + dn / x;
        const C a = (ta * psi - psi1) / (ta * xi - xi1);
        const C b = (tb * psi - psi1) / (tb * xi - xi1);

        qsca += (2.0 * dn + 1.0) * (std::norm(a) + std::norm(b));
        qext += (2.0 * dn + 1.0) * (a.real() + b.real());
        back += (2.0 * dn + 1.0) * (n % 2 ? -1.0 : 1.0) * (a - b);
        if (n > 1)
            g += (dn - 1.0) * (dn + 1.0) / dn *
                     (aPrev * std::conj(a) + bPrev * std::conj(b)).real() +
                 (2.0 * dn - 1.0) / ((dn - 1.0) * dn) * (aPrev * std::conj(bPrev)).real();

        const double f = (2.0 * dn + 1.0) / (dn * (dn + 1.0));
        for (size_t k = 0; k < angles; ++k) {
            const double pi = piCur[k];
            const double tau = dn * mu[k] * pi - (dn + 1.0) * piPrev[k];
            s1[k] += f * (a * pi + b * tau);
            s2[k] += f * (a * tau + b * pi);
            // pi_{n+1} = ((2n + 1) mu pi_n - (n + 1) pi_{n-1}) / n
            const double next = ((2.0 * dn + 1.0) * mu[k] * pi - (dn + 1.0) * piPrev[k]) / dn;
            piPrev[k] = pi;
            piCur[k] = next;
        }
        aPrev = a;
        bPrev = b;
        psi0 = psi1;
        psi1 = psi;
        chi0 = chi1;
        chi1 = chi;
        xi1 = C(psi1, -chi1);
    }
    // The last order's own term of g (its partner a_{nStop+1} is 0).
    {
        const double dn = nStop + 1.0;
        g += (2.0 * dn - 1.0) / ((dn - 1.0) * dn) * (aPrev * std::conj(bPrev)).real();
    }
    const double x2 = x * x;
    e.qsca = 2.0 / x2 * qsca;
    e.qext = 2.0 / x2 * qext;
    e.qback = std::norm(back) / x2;
    e.asymmetry = qsca > 0.0 ? 4.0 / x2 * g / e.qsca : 0.0;
    if (intensity) {
        intensity->resize(angles);
        for (size_t k = 0; k < angles; ++k)
            (*intensity)[k] = 0.5 * (std::norm(s1[k]) + std::norm(s2[k]));
    }
    return e;
}

}  // namespace veil
