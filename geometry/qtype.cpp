#include "geometry/qtype.h"

#include <gmpxx.h>

#include <array>
#include <cmath>
#include <stdexcept>

namespace veil {

namespace {

using Poly = std::vector<mpq_class>;  // coefficients by power

Poly multiply(const Poly& a, const Poly& b) {
    Poly out(a.size() + b.size() - 1, mpq_class(0));
    for (size_t i = 0; i < a.size(); ++i)
        for (size_t j = 0; j < b.size(); ++j) out[i + j] += a[i] * b[j];
    return out;
}

Poly derivative(const Poly& a) {
    if (a.size() < 2) return {mpq_class(0)};
    Poly out(a.size() - 1);
    for (size_t i = 1; i < a.size(); ++i) out[i - 1] = a[i] * static_cast<long>(i);
    return out;
}

// Q(x) in powers of x -> f(u) = u^2 (1 - u^2) Q(u^2) in powers of u.
Poly slopeBasis(const Poly& q) {
    Poly qu(2 * q.size() - 1, mpq_class(0));
    for (size_t i = 0; i < q.size(); ++i) qu[2 * i] = q[i];
    return derivative(multiply({0, 0, 1, 0, -1}, qu));
}

// integral_0^1 u^k du / sqrt(1 - u^2) / (pi / 2) for even k: (k - 1)!! / k!!.
mpq_class evenMoment(size_t k) {
    mpq_class r(1);
    for (size_t i = 2; i <= k; i += 2) r *= mpq_class(static_cast<long>(i - 1), static_cast<long>(i));
    return r;
}

// <f', g'> / (pi / 2); the products of two odd polynomials in u hold even powers only.
mpq_class inner(const Poly& fd, const Poly& gd) {
    const Poly p = multiply(fd, gd);
    mpq_class s(0);
    for (size_t k = 0; k < p.size(); ++k) {
        if (p[k] == 0) continue;
        if (k % 2 != 0) throw std::logic_error("Q-bfs inner product: odd power");
        s += p[k] * evenMoment(k);
    }
    return s;
}

std::array<std::vector<double>, kMaxQTerms> buildQbfs() {
    std::array<std::vector<double>, kMaxQTerms> out;
    std::vector<Poly> basis, slopes;  // orthogonal, not yet normalised
    std::vector<mpq_class> norms;
    for (int m = 0; m < kMaxQTerms; ++m) {
        Poly q(static_cast<size_t>(m) + 1, mpq_class(0));
        q[static_cast<size_t>(m)] = 1;
        const Poly qs = slopeBasis(q);
        for (size_t j = 0; j < basis.size(); ++j) {
            const mpq_class coef = inner(qs, slopes[j]) / norms[j];
            for (size_t i = 0; i < basis[j].size(); ++i) q[i] -= coef * basis[j][i];
        }
        const Poly s = slopeBasis(q);
        const mpq_class n = inner(s, s);
        basis.push_back(q);
        slopes.push_back(s);
        norms.push_back(n);
        // Normalised to (pi / 2), with Q_m(0) > 0.
        const double scale = (q[0] > 0 ? 1.0 : -1.0) / std::sqrt(n.get_d());
        for (const mpq_class& c : q) out[static_cast<size_t>(m)].push_back(c.get_d() * scale);
    }
    return out;
}

std::array<std::vector<double>, kMaxQTerms> buildQcon() {
    // P_m^(0,4)(2x - 1) = sum_s C(m, m - s) C(m + 4, s) (x - 1)^s x^(m - s).
    auto binomial = [](long n, long k) {
        mpz_class r;
        mpz_bin_uiui(r.get_mpz_t(), static_cast<unsigned long>(n), static_cast<unsigned long>(k));
        return mpq_class(r);
    };
    std::array<std::vector<double>, kMaxQTerms> out;
    for (int m = 0; m < kMaxQTerms; ++m) {
        Poly q(static_cast<size_t>(m) + 1, mpq_class(0));
        for (int s = 0; s <= m; ++s) {
            Poly term{binomial(m, m - s) * binomial(m + 4, s)};
            for (int i = 0; i < s; ++i) term = multiply(term, {-1, 1});
            for (int i = 0; i < m - s; ++i) term = multiply(term, {0, 1});
            for (size_t i = 0; i < term.size(); ++i) q[i] += term[i];
        }
        for (const mpq_class& c : q) out[static_cast<size_t>(m)].push_back(c.get_d());
    }
    return out;
}

void checkTerms(double rNormMm, const std::vector<double>& terms) {
    if (!(rNormMm > 0.0) || !std::isfinite(rNormMm))
        throw std::invalid_argument("Q-type normalisation radius must be finite and > 0");
    if (terms.size() > static_cast<size_t>(kMaxQTerms))
        throw std::invalid_argument("at most " + std::to_string(kMaxQTerms) + " Q-type terms");
}

// sum_m a_m prefix(x) Q_m(x) in powers of v = r^2: x^n -> v^n / rNorm^(2n).
std::vector<double> departure(double rNormMm, const std::vector<double>& terms,
                              const std::vector<double>& prefix,
                              const std::vector<double>& (*poly)(int)) {
    checkTerms(rNormMm, terms);
    // Degree (prefix.size() - 1) + (terms.size() - 1): Q_m has degree m.
    std::vector<long double> inX(prefix.size() + terms.size() - 1, 0.0L);
    for (size_t m = 0; m < terms.size(); ++m) {
        const std::vector<double>& q = poly(static_cast<int>(m));
        for (size_t i = 0; i < q.size(); ++i)
            for (size_t p = 0; p < prefix.size(); ++p)
                inX[i + p] += static_cast<long double>(terms[m]) * q[i] * prefix[p];
    }
    std::vector<double> out(inX.size(), 0.0);
    const long double v1 = 1.0L / (static_cast<long double>(rNormMm) * rNormMm);
    long double scale = 1.0L;
    for (size_t n = 0; n < inX.size(); ++n) {
        out[n] = static_cast<double>(inX[n] * scale);
        scale *= v1;
    }
    return out;
}

}  // namespace

const std::vector<double>& qconPolynomial(int m) {
    static const auto table = buildQcon();
    return table.at(static_cast<size_t>(m));
}

const std::vector<double>& qbfsPolynomial(int m) {
    static const auto table = buildQbfs();
    return table.at(static_cast<size_t>(m));
}

std::vector<double> qconDeparture(double rNormMm, const std::vector<double>& terms) {
    return departure(rNormMm, terms, {0.0, 0.0, 1.0}, &qconPolynomial);  // u^4 = x^2
}

std::vector<double> qbfsDeparture(double rNormMm, const std::vector<double>& terms) {
    return departure(rNormMm, terms, {0.0, 1.0, -1.0}, &qbfsPolynomial);  // x (1 - x)
}

}  // namespace veil
