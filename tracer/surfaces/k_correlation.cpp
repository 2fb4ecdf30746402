#include "tracer/surfaces/k_correlation.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "geometry/numerics.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/lobe_math.h"

namespace veil {

namespace {

constexpr int kMaxTries = 1024;

// The table's grid. Incidence: theta = (pi / 2)(1 - (1 - t)^2), t uniform, so the knots
// crowd toward grazing, where a narrow lobe meets the edge of the disk. Width: ln l uniform,
// 12 knots per decade, over the l of vacuum wavelengths 100 nm to 30 um in indices 1 to 5.
constexpr int kIncidenceIntervals = 96;
constexpr double kKnotsPerDecade = 12.0;
constexpr double kMinWavelengthUm = 0.1, kMaxWavelengthUm = 30.0, kMaxIndex = 5.0;

double thetaOfT(double t) { return 0.5 * kPi * (1.0 - (1.0 - t) * (1.0 - t)); }
double tOfB0(double b0) {
    const double theta = std::asin(std::clamp(b0, 0.0, 1.0));
    return 1.0 - std::sqrt(std::max(0.0, 1.0 - theta / (0.5 * kPi)));
}

// Catmull-Rom through p1 (f = 0) and p2 (f = 1); p0 and p3 the outer neighbours.
double catmullRom(double p0, double p1, double p2, double p3, double f) {
    return p1 + 0.5 * f *
                    (p2 - p0 +
                     f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)));
}

}  // namespace

std::ostream& operator<<(std::ostream& os, const KCorrelationParams& p) {
    os << "k_correlation{A " << p.aNm2Um2 << " nm^2 um^2, B " << p.bUm << " um, C " << p.c;
    if (p.reflectance > 0.0) os << ", R " << p.reflectance;
    if (p.transmission) os << ", BTDF";
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const KcLobe& l) {
    return os << "KcLobe{scale " << l.scale << "/sr, l " << l.l << ", b0 " << l.b0
              << (l.cosWeighted ? ", cos-weighted" : "") << "}";
}

double kCorrelationA(double sigmaNm, double bUm, double c) {
    if (!(sigmaNm >= 0.0) || !std::isfinite(sigmaNm))
        throw std::invalid_argument("RMS roughness sigma must be >= 0");
    if (!(bUm > 0.0) || !std::isfinite(bUm))
        throw std::invalid_argument("correlation length B must be > 0");
    if (!(c > 2.0) || !std::isfinite(c))
        throw std::invalid_argument(
            "the RMS roughness of a K-correlation PSD is finite only for C > 2 (give A, B "
            "and C for flatter spectra)");
    return sigmaNm * sigmaNm * bUm * bUm * (c - 2.0) / (2.0 * kPi);
}

// The TIS tables: J (1 + l^2) on the (t, ln l) grid, J = shapeIntegral, which tends to a
// constant for narrow lobes (C > 2) and falls as 1 / l^2 for wide ones: the factor keeps the
// tabulated function flat at both ends.
struct KCorrelationScatter::Table {
    double lnLMin = 0.0, lnLStep = 1.0;
    int widthIntervals = 0;
    std::vector<double> j;  // [width knot][incidence knot]
    double at(int w, int t) const { return j[w * (kIncidenceIntervals + 1) + t]; }
};

KCorrelationScatter::KCorrelationScatter(const KCorrelationParams& p) : p_(p) {
    if (!(p.aNm2Um2 >= 0.0) || !std::isfinite(p.aNm2Um2))
        throw std::invalid_argument("K-correlation A must be >= 0");
    if (!(p.bUm > 0.0) || !std::isfinite(p.bUm))
        throw std::invalid_argument("K-correlation B must be > 0");
    if (!(p.c > 0.0) || !std::isfinite(p.c) || p.c > 1e3)
        throw std::invalid_argument("K-correlation C must be in (0, 1000]");
    if (!(p.reflectance >= 0.0 && p.reflectance <= 1.0))
        throw std::invalid_argument("K-correlation reflectance must be in [0, 1]");
    if (!(p.reflectance > 0.0) && !p.transmission)
        throw std::invalid_argument(
            "K-correlation scatter needs a reflectance > 0 (a BRDF) or transmission (a BTDF)");

    auto build = [&](bool cosWeighted) {
        auto t = std::make_shared<Table>();
        const double lMin = kMinWavelengthUm / (kMaxIndex * p.bUm);
        const double lMax = kMaxWavelengthUm / p.bUm;
        t->lnLMin = std::log(lMin);
        t->widthIntervals =
            std::max(4, static_cast<int>(std::ceil(std::log10(lMax / lMin) * kKnotsPerDecade)));
        t->lnLStep = std::log(lMax / lMin) / t->widthIntervals;
        t->j.resize((t->widthIntervals + 1) * (kIncidenceIntervals + 1));
        tbb::parallel_for(0, t->widthIntervals + 1, [&](int w) {
            const double l = std::exp(t->lnLMin + w * t->lnLStep);
            for (int i = 0; i <= kIncidenceIntervals; ++i) {
                const double b0 = i == kIncidenceIntervals
                                      ? 1.0
                                      : std::sin(thetaOfT(double(i) / kIncidenceIntervals));
                t->j[w * (kIncidenceIntervals + 1) + i] =
                    shapeIntegral(b0, l, cosWeighted) * (1.0 + l * l);
            }
        });
        return std::shared_ptr<const Table>(std::move(t));
    };
    if (reflects()) reflectTable_ = build(true);
    if (transmits()) transmitTable_ = build(false);
}

double KCorrelationScatter::psd(double fPerUm) const {
    const double bf = p_.bUm * fPerUm;
    return p_.aNm2Um2 * std::pow(1.0 + bf * bf, -0.5 * p_.c);
}

double KCorrelationScatter::bandSigmaNm(double f0PerUm, double f1PerUm) const {
    // 2 pi integral f A (1 + B^2 f^2)^(-C/2) df = (pi A / B^2) [G(B^2 f^2)], G(x) the
    // integral of (1 + x)^(-C/2): ln(1 + x) at C = 2, (1 + x)^(1 - C/2) / (1 - C/2) otherwise.
    const double q = 1.0 - 0.5 * p_.c;
    auto g = [&](double f) {
        if (std::isinf(f)) {
            if (q >= 0.0) return std::numeric_limits<double>::infinity();
            return 0.0;
        }
        const double x = p_.bUm * p_.bUm * f * f;
        const double l = std::log1p(x);
        return q == 0.0 ? l : std::expm1(q * l) / q;  // shifted by a constant: differences only
    };
    const double g0 = g(f0PerUm), g1 = g(f1PerUm);
    const double var = kPi * p_.aNm2Um2 / (p_.bUm * p_.bUm) *
                       (std::isinf(f1PerUm) && q < 0.0 ? -1.0 / q - g0 : g1 - g0);
    return std::sqrt(std::max(0.0, var));
}

KcLobe KCorrelationScatter::reflectLobe(double wavelengthNm, double n1, double cosI) const {
    KcLobe lobe;
    lobe.cosWeighted = true;
    cosI = std::clamp(cosI, 0.0, 1.0);
    lobe.b0 = std::sqrt(std::max(0.0, 1.0 - cosI * cosI));
    const double lambdaUm = wavelengthNm * 1e-3 / n1;
    lobe.l = lambdaUm / p_.bUm;
    if (!reflects()) return lobe;
    const double a = p_.aNm2Um2 * 1e-6;  // um^4
    const double l2 = lambdaUm * lambdaUm;
    lobe.scale = 16.0 * kPi * kPi * cosI * p_.reflectance * a / (l2 * l2);
    return lobe;
}

KcLobe KCorrelationScatter::transmitLobe(double wavelengthNm, double n1, double n2, double cosI,
                                         double cosT) const {
    KcLobe lobe;
    cosI = std::clamp(cosI, 0.0, 1.0);
    lobe.b0 = std::min(1.0, n1 / n2 * std::sqrt(std::max(0.0, 1.0 - cosI * cosI)));
    const double lambdaUm = wavelengthNm * 1e-3;
    lobe.l = lambdaUm / (n2 * p_.bUm);
    if (!transmits()) return lobe;
    const double a = p_.aNm2Um2 * 1e-6;
    const double l2 = lambdaUm * lambdaUm;
    const double delta = n1 * cosI - n2 * cosT;
    lobe.scale = 4.0 * kPi * kPi * n2 * n2 * delta * delta * a / (l2 * l2);
    return lobe;
}

double KCorrelationScatter::bsdf(const KcLobe& lobe, double r, double cosOut) const {
    const double x = r / lobe.l;
    const double v = lobe.scale * std::pow(1.0 + x * x, -0.5 * p_.c);
    return lobe.cosWeighted ? v * std::max(0.0, cosOut) : v;
}

double KCorrelationScatter::shapeIntegral(double b0, double l, bool cosWeighted, bool fine) const {
    // Polar coordinates (r, phi) about beta0, r = l x: the radial measure r (1 + x^2)^(-C/2) dr
    // is l^2 dG(x), G(x) = powerLobeRadialCdf(x, 1, C/2); over the variable v = G(x) / G(xmax)
    // the integral is G(xmax) times the mean over v of the circle's weight A(r) (2 pi times
    // the fraction inside the disk; the integral of cos(s) over that arc when cos-weighted).
    // A(r) has square-root behaviour where the circle starts to leave the disk and at the ends
    // of the arc: the integral splits there and both parts take the endpoint substitution.
    b0 = std::clamp(b0, 0.0, 1.0);
    const double p = 0.5 * p_.c;
    const double gMax = lobe::powerLobeRadialCdf((1.0 + b0) / l, 1.0, p);
    auto rOf = [&](double v) { return l * lobe::inversePowerLobeRadialCdf(v * gMax, 1.0, p); };
    auto weight = [&](double r) {
        if (!cosWeighted) return 2.0 * kPi * lobe::circleFractionInDisk(r, b0);
        const double base = 1.0 - b0 * b0 - r * r;  // 1 - |beta|^2 at phi = pi / 2
        if (b0 * r == 0.0) return base > 0.0 ? 2.0 * kPi * std::sqrt(base) : 0.0;
        // phi from beta0's direction: |beta|^2 = b0^2 + r^2 + 2 b0 r cos(phi), inside the disk
        // for cos(phi) < base / (2 b0 r).
        const double c = base / (2.0 * b0 * r);
        if (c <= -1.0) return 0.0;
        const double phi0 = c >= 1.0 ? 0.0 : std::acos(c);
        auto f = [&](double phi) {
            return std::sqrt(std::max(0.0, base - 2.0 * b0 * r * std::cos(phi)));
        };
        return 2.0 * (fine ? lobe::integrateEndpointSqrt<96>(phi0, kPi, f)
                           : lobe::integrateEndpointSqrt<24>(phi0, kPi, f));
    };
    const double va = lobe::powerLobeRadialCdf((1.0 - b0) / l, 1.0, p) / gMax;
    auto w = [&](double v) { return weight(rOf(v)); };
    const double inner = fine ? lobe::integrateEndpointSqrt<128>(0.0, va, w)
                              : lobe::integrateEndpointSqrt<32>(0.0, va, w);
    const double outer = fine ? lobe::integrateEndpointSqrt<128>(va, 1.0, w)
                              : lobe::integrateEndpointSqrt<32>(va, 1.0, w);
    return gMax * (inner + outer);
}

double KCorrelationScatter::shapeFromTable(const Table& t, double b0, double l,
                                           bool cosWeighted) const {
    const double u = (std::log(l) - t.lnLMin) / t.lnLStep;
    if (!(u >= 0.0 && u <= t.widthIntervals)) return shapeIntegral(b0, l, cosWeighted);
    const double x = tOfB0(b0) * kIncidenceIntervals;
    const int i = std::clamp(static_cast<int>(x), 0, kIncidenceIntervals - 1);
    const int w = std::clamp(static_cast<int>(u), 0, t.widthIntervals - 1);
    const double fi = x - i, fw = u - w;
    // Bicubic: Catmull-Rom across incidence at four widths, then across width. Past the
    // grid's edges the neighbour is extrapolated linearly.
    auto alongIncidence = [&](int ww) {
        ww = std::clamp(ww, 0, t.widthIntervals);
        const double p1 = t.at(ww, i), p2 = t.at(ww, i + 1);
        const double p0 = i > 0 ? t.at(ww, i - 1) : 2.0 * p1 - p2;
        const double p3 = i + 2 <= kIncidenceIntervals ? t.at(ww, i + 2) : 2.0 * p2 - p1;
        return catmullRom(p0, p1, p2, p3, fi);
    };
    const double q1 = alongIncidence(w), q2 = alongIncidence(w + 1);
    const double q0 = w > 0 ? alongIncidence(w - 1) : 2.0 * q1 - q2;
    const double q3 = w + 2 <= t.widthIntervals ? alongIncidence(w + 2) : 2.0 * q2 - q1;
    return std::max(0.0, catmullRom(q0, q1, q2, q3, fw)) / (1.0 + l * l);
}

double KCorrelationScatter::tis(const KcLobe& lobe) const {
    if (lobe.scale <= 0.0) return 0.0;
    const Table* t = lobe.cosWeighted ? reflectTable_.get() : transmitTable_.get();
    const double j = t ? shapeFromTable(*t, lobe.b0, lobe.l, lobe.cosWeighted)
                       : shapeIntegral(lobe.b0, lobe.l, lobe.cosWeighted);
    return lobe.scale * lobe.l * lobe.l * j;
}

double KCorrelationScatter::tisExact(const KcLobe& lobe) const {
    if (lobe.scale <= 0.0) return 0.0;
    return lobe.scale * lobe.l * lobe.l * shapeIntegral(lobe.b0, lobe.l, lobe.cosWeighted, true);
}

bool KCorrelationScatter::sample(const KcLobe& lobe, const Vec2& beta0, double u1, double u2,
                                 Vec2& beta) const {
    const double p = 0.5 * p_.c;
    const double gMax = lobe::powerLobeRadialCdf((1.0 + lobe.b0) / lobe.l, 1.0, p);
    // The first try takes (u1, u2); the rest, and the cos(s) acceptance, come from a stream
    // keyed by their bits, so the outcome is a function of (u1, u2) alone.
    CounterRng rng(std::bit_cast<uint64_t>(u1), std::bit_cast<uint64_t>(u2));
    double a = u1, b = u2;
    for (int k = 0; k < kMaxTries; ++k) {
        if (k > 0) {
            a = rng.uniform();
            b = rng.uniform();
        }
        const double r = lobe.l * lobe::inversePowerLobeRadialCdf(a * gMax, 1.0, p);
        const double phi = 2.0 * kPi * b;
        const Vec2 candidate = beta0 + r * Vec2(std::cos(phi), std::sin(phi));
        const double rho2 = glm::dot(candidate, candidate);
        if (!(rho2 < 1.0)) continue;
        if (lobe.cosWeighted && !(rng.uniform() < std::sqrt(1.0 - rho2))) continue;
        beta = candidate;
        return true;
    }
    return false;
}

}  // namespace veil
