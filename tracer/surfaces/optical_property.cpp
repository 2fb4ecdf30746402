#include "tracer/surfaces/optical_property.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "geometry/numerics.h"
#include "lensdata/errors.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/surfaces/fresnel.h"
#include "tracer/surfaces/lobe_math.h"

namespace veil {

namespace {

constexpr double kDeg = kPi / 180.0;
constexpr int kMaxTries = 256;

template <class... Ts>
struct Overloaded : Ts... {
    using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

// Orthonormal basis with n as the third axis (Duff et al., JCGT 2017).
void basisAround(const Vec3& n, Vec3& t1, Vec3& t2) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double b = n.x * n.y * a;
    t1 = Vec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    t2 = Vec3(b, sign + n.y * n.y * a, -n.y);
}

// Draws (u1, u2) pairs until `attempt` accepts one: first the given pair, then pairs from a
// CounterRng keyed by their bits, so the outcome is a function of (u1, u2) alone.
template <class F>
bool sampleWithRejection(double u1, double u2, F&& attempt, int maxTries = kMaxTries) {
    if (attempt(u1, u2)) return true;
    CounterRng rng(std::bit_cast<uint64_t>(u1), std::bit_cast<uint64_t>(u2));
    for (int k = 1; k < maxTries; ++k) {
        const double a = rng.uniform(), b = rng.uniform();
        if (attempt(a, b)) return true;
    }
    return false;
}

// Fraction of a circle of angular radius alpha about an axis at angle thetaS from the side
// normal that lies in the open hemisphere about that normal.
double circleFractionAbove(double cosAlpha, double sinAlpha, double cosS, double sinS) {
    if (sinAlpha <= 0.0 || sinS <= 0.0) return cosAlpha * cosS > 0.0 ? 1.0 : 0.0;
    const double c = -cosAlpha * cosS / (sinAlpha * sinS);
    return std::acos(std::clamp(c, -1.0, 1.0)) / kPi;
}

void requireFraction(double v, const char* what) {
    if (!(v >= 0.0 && v <= 1.0))
        throw std::invalid_argument(std::string(what) + " must be in [0, 1] (got " +
                                    std::to_string(v) + ")");
}

}  // namespace

// Surface Context and Channels

double SurfaceContext::cosIncidence() const {
    return std::clamp(-glm::dot(direction, normal), 0.0, 1.0);
}

std::ostream& operator<<(std::ostream& os, const SurfaceContext& c) {
    os << "SurfaceContext{dir " << c.direction << ", normal " << c.normal << ", n1 " << c.n1
       << ", n2 " << c.n2 << ", " << c.wavelengthNm << " nm";
    if (c.opaque) os << ", opaque";
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const Channels& c) {
    os << "Channels{specR " << c.specularReflect << ", specT " << c.specularTransmit << ", scatR "
       << c.scatterReflect << ", scatT " << c.scatterTransmit << ", absorbed " << c.absorbed();
    if (c.tir) os << ", TIR";
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const ScatterSample& s) {
    return os << "ScatterSample{" << s.direction << ", pdf " << s.pdf << "}";
}

std::ostream& operator<<(std::ostream& os, const SpecularModel& m) {
    std::visit(Overloaded{
                   [&](const FresnelSpecular&) { os << "fresnel"; },
                   [&](const IdealArSpecular&) { os << "ideal_ar"; },
                   [&](const FixedSpecular& f) {
                       os << "fixed{R " << f.reflectance << ", T " << f.transmittance << "}";
                   },
                   [&](const QuarterWaveSpecular& q) {
                       os << "quarter_wave{index " << q.index << ", " << q.designNm << " nm}";
                   },
                   [&](const MirrorSpecular& mm) { os << "mirror{R " << mm.reflectance << "}"; },
                   [&](const AbsorberSpecular&) { os << "absorber"; },
               },
               m);
    return os;
}

std::ostream& operator<<(std::ostream& os, const AbgParams& p) {
    // g = 2 is a Harvey-Shack lobe: b0 = A / B^p, l = sqrt(B), s = -2p.
    if (p.g == 2.0 && p.p != 1.0)
        return os << "{b0 " << p.a / std::pow(p.b, p.p) << ", l " << std::sqrt(p.b) << ", s "
                  << -2.0 * p.p << "}";
    os << "{A " << p.a << ", B " << p.b << ", g " << p.g;
    if (p.p != 1.0) os << ", p " << p.p;
    return os << "}";
}

AbgParams harveyShack(double b0, double l, double s) {
    if (!(b0 >= 0.0) || !std::isfinite(b0))
        throw std::invalid_argument("Harvey-Shack b0 must be >= 0");
    if (!(l > 0.0) || !std::isfinite(l)) throw std::invalid_argument("Harvey-Shack l must be > 0");
    if (!(s <= 0.0) || !std::isfinite(s))
        throw std::invalid_argument("Harvey-Shack s must be <= 0");
    return AbgParams{b0 * std::pow(l, -s), l * l, 2.0, -0.5 * s};
}

std::ostream& operator<<(std::ostream& os, const ScatterModel& m) {
    std::visit(Overloaded{
                   [&](const NoScatter&) { os << "none"; },
                   [&](const LambertianScatter& l) {
                       os << "lambertian{R " << l.reflectance << ", T " << l.transmittance << "}";
                   },
                   [&](const GaussianScatter& g) {
                       os << "gaussian{R " << g.reflectance() << ", T " << g.transmittance()
                          << ", HWHM " << g.halfWidthDeg() << " deg}";
                   },
                   [&](const AbgScatter& a) {
                       bool hs = true;
                       for (bool t : {false, true})
                           for (const auto& l : a.lobes(t))
                               hs = hs && l->params().g == 2.0 && l->params().p != 1.0;
                       os << (hs ? "harvey_shack{" : "abg{");
                       for (bool t : {false, true}) {
                           if (!a.has(t)) continue;
                           if (t && a.has(false)) os << ", ";
                           os << (t ? "btdf " : "brdf ");
                           for (size_t k = 0; k < a.lobes(t).size(); ++k)
                               os << (k ? " + " : "") << a.lobes(t)[k]->params();
                       }
                       os << "}";
                   },
                   [&](const KCorrelationScatter& k) { os << k.params(); },
                   [&](const TabulatedScatter& t) { os << t; },
                   [&](const ParticulateScatter& d) { os << d.params(); },
               },
               m);
    return os;
}

// Gaussian Lobe

GaussianScatter::GaussianScatter(double reflectance, double transmittance, double halfWidthDeg)
    : reflectance_(reflectance), transmittance_(transmittance), halfWidthDeg_(halfWidthDeg) {
    requireFraction(reflectance, "Gaussian reflectance");
    requireFraction(transmittance, "Gaussian transmittance");
    if (reflectance + transmittance > 1.0)
        throw std::invalid_argument("Gaussian reflectance + transmittance must be <= 1");
    if (!(halfWidthDeg > 0.0 && halfWidthDeg <= 90.0))
        throw std::invalid_argument("Gaussian half width must be in (0, 90] degrees");
    const double s = std::sin(0.5 * halfWidthDeg * kPi / 180.0);
    kappa_ = std::log(2.0) / (2.0 * s * s);  // ln 2 / (1 - cos w)
    norm_ = -std::expm1(-2.0 * kappa_);
}

// With w = 1 - cos(a): the unclipped lobe has intensity kappa exp(-kappa w) / (2 pi norm) per
// steradian, CDF F(w) = (1 - exp(-kappa w)) / norm for w in [0, 2].
double GaussianScatter::hemisphereMass(double cosAxisSide) const {
    const double cosS = std::clamp(cosAxisSide, 0.0, 1.0);
    const double sinS = std::sqrt(std::max(0.0, 1.0 - cosS * cosS));
    auto cdf = [&](double w) { return -std::expm1(-kappa_ * w) / norm_; };
    if (sinS == 0.0) return cdf(1.0);
    // Below w1 the whole circle is above the horizon; above w2 none of it.
    const double ua = cdf(1.0 - sinS), ub = cdf(1.0 + sinS);
    if (ub - ua < 1e-10) return ua + 0.5 * (ub - ua);  // all but < 1e-10 above the horizon
    const double middle = lobe::integrateEndpointSqrt(ua, ub, [&](double u) {
        const double w = std::min(2.0, -std::log1p(-u * norm_) / kappa_);
        return circleFractionAbove(1.0 - w, std::sqrt(std::max(0.0, w * (2.0 - w))), cosS, sinS);
    });
    return ua + middle;
}

double GaussianScatter::pdf(const Vec3& axis, const Vec3& side, const Vec3& w) const {
    if (!(glm::dot(w, side) > 0.0)) return 0.0;
    const Vec3 d = axis - w;
    const double oneMinusCos = 0.5 * glm::dot(d, d);
    const double density = kappa_ * std::exp(-kappa_ * oneMinusCos) / (2.0 * kPi * norm_);
    return density / hemisphereMass(glm::dot(axis, side));
}

ScatterSample GaussianScatter::sample(const Vec3& axis, const Vec3& side, double u1,
                                      double u2) const {
    Vec3 t1, t2;
    basisAround(axis, t1, t2);
    Vec3 out = axis;
    const bool ok = sampleWithRejection(u1, u2, [&](double a, double b) {
        const double w = std::min(2.0, -std::log1p(-a * norm_) / kappa_);
        const double sinA = std::sqrt(std::max(0.0, w * (2.0 - w)));
        const double phi = 2.0 * kPi * b;
        const Vec3 d = (1.0 - w) * axis + sinA * (std::cos(phi) * t1 + std::sin(phi) * t2);
        if (!(glm::dot(d, side) > 0.0)) return false;
        out = glm::normalize(d);
        return true;
    });
    if (!ok) out = axis;
    return {out, pdf(axis, side, out)};
}

// ABg Lobe

namespace {
constexpr int kRadialKnots = 400;  // geometric knots on [r1, 2]
constexpr int kTisIntervals = 1024;
}  // namespace

AbgLobe::AbgLobe(const AbgParams& p) : p_(p) {
    if (!(p.a >= 0.0) || !std::isfinite(p.a)) throw std::invalid_argument("ABg A must be >= 0");
    if (!(p.b > 0.0) || !std::isfinite(p.b)) throw std::invalid_argument("ABg B must be > 0");
    if (!(p.g >= 0.0) || !std::isfinite(p.g)) throw std::invalid_argument("ABg g must be >= 0");
    if (!(p.p >= 0.0) || !std::isfinite(p.p))
        throw std::invalid_argument("the lobe's exponent p must be >= 0");

    // Radial CDF of r / (B + r^g): exact (8-point Gauss) on knots that are geometric from well
    // inside the lobe's core (r ~ B^(1/g)) out to r = 2, the largest |beta - beta0|.
    const double core = p.g > 0.0 ? std::min(1.0, std::pow(p.b, 1.0 / p.g)) : 1.0;
    knot1_ = 1e-4 * core;
    logRatio_ = std::log(2.0 / knot1_) / (kRadialKnots - 1);
    knotR_.resize(kRadialKnots + 1);
    knotCdf_.resize(kRadialKnots + 1);
    knotR_[0] = 0.0;
    for (int k = 1; k <= kRadialKnots; ++k) knotR_[k] = knot1_ * std::exp((k - 1) * logRatio_);
    knotR_[kRadialKnots] = 2.0;
    knotCdf_[0] = 0.0;
    for (int k = 1; k <= kRadialKnots; ++k)
        knotCdf_[k] = p.g == 2.0 ? radialCdf(knotR_[k])
                                 : knotCdf_[k - 1] + partialIntegral(knotR_[k - 1], knotR_[k]);

    tisTable_.resize(kTisIntervals + 1);
    for (int i = 0; i <= kTisIntervals; ++i) {
        const double theta = 0.5 * kPi * i / kTisIntervals;
        tisTable_[i] = tisExact(i == kTisIntervals ? 1.0 : std::sin(theta));
        maxTis_ = std::max(maxTis_, tisTable_[i]);
    }
}

double AbgLobe::bsdf(double r) const {
    const double d = p_.b + std::pow(r, p_.g);
    return p_.a / (p_.p == 1.0 ? d : std::pow(d, p_.p));
}

double AbgLobe::radialDensity(double r) const {
    const double d = p_.b + std::pow(r, p_.g);
    return r / (p_.p == 1.0 ? d : std::pow(d, p_.p));
}

double AbgLobe::partialIntegral(double r0, double r1) const {
    const auto& g = lobe::gauss<8>();
    const double h = 0.5 * (r1 - r0), m = 0.5 * (r1 + r0);
    double sum = 0.0;
    for (int i = 0; i < 8; ++i) sum += g.w[i] * radialDensity(m + h * g.x[i]);
    return sum * h;
}

double AbgLobe::radialCdf(double r) const {
    r = std::clamp(r, 0.0, 2.0);
    if (p_.g == 2.0) return lobe::powerLobeRadialCdf(r, p_.b, p_.p);  // closed form
    if (r <= knotR_[1]) return partialIntegral(0.0, r);
    int k = 1 + static_cast<int>(std::floor(std::log(r / knot1_) / logRatio_));
    k = std::clamp(k, 1, kRadialKnots - 1);
    while (k > 1 && knotR_[k] > r) --k;
    while (k < kRadialKnots - 1 && knotR_[k + 1] <= r) ++k;
    return knotCdf_[k] + partialIntegral(knotR_[k], r);
}

double AbgLobe::inverseRadialCdf(double c) const {
    c = std::clamp(c, 0.0, knotCdf_.back());
    if (p_.g == 2.0) return std::min(2.0, lobe::inversePowerLobeRadialCdf(c, p_.b, p_.p));
    int k =
        static_cast<int>(std::upper_bound(knotCdf_.begin(), knotCdf_.end(), c) - knotCdf_.begin()) -
        1;
    k = std::clamp(k, 0, kRadialKnots - 1);
    double lo = knotR_[k], hi = knotR_[k + 1];
    const double target = c - knotCdf_[k];
    const double span = knotCdf_[k + 1] - knotCdf_[k];
    if (span <= 0.0) return lo;
    // Safeguarded Newton on the exact partial integral, from linear interpolation.
    double r = lo + (hi - lo) * std::clamp(target / span, 0.0, 1.0);
    for (int it = 0; it < 60; ++it) {
        const double f = partialIntegral(knotR_[k], r) - target;
        if (std::abs(f) <= 1e-15 * knotCdf_.back()) break;
        if (f > 0.0)
            hi = r;
        else
            lo = r;
        const double dens = radialDensity(r);
        double next = dens > 0.0 ? r - f / dens : 0.5 * (lo + hi);
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        const bool converged = std::abs(next - r) <= 1e-14 * hi || hi - lo <= 1e-15 * hi;
        r = next;
        if (converged) break;
    }
    return r;
}

double AbgLobe::tisExact(double b0) const {
    b0 = std::clamp(b0, 0.0, 1.0);
    const double inner = radialCdf(1.0 - b0);  // circles wholly inside the disk
    if (b0 == 0.0) return 2.0 * kPi * p_.a * inner;
    const double outer = radialCdf(1.0 + b0);
    // Over the radial CDF variable v (uniform under the unclipped radial distribution): the
    // fraction of each circle inside the disk, 1 up to va.
    const double va = inner / outer;
    const double middle = lobe::integrateEndpointSqrt(va, 1.0, [&](double v) {
        return lobe::circleFractionInDisk(inverseRadialCdf(v * outer), b0);
    });
    return 2.0 * kPi * p_.a * (inner + outer * middle);
}

double AbgLobe::tis(double b0) const {
    const double x = std::asin(std::clamp(b0, 0.0, 1.0)) / (0.5 * kPi) * kTisIntervals;
    const int i = std::clamp(static_cast<int>(x), 0, kTisIntervals - 1);
    const double f = x - i;
    // Cubic (Catmull-Rom) through the four nearest knots. Past its ends the table continues
    // by symmetry: b0 = sin(theta) is even about theta = 0 and about theta = pi/2.
    const double p1 = tisTable_[i], p2 = tisTable_[i + 1];
    const double p0 = i > 0 ? tisTable_[i - 1] : tisTable_[1];
    const double p3 = i + 2 <= kTisIntervals ? tisTable_[i + 2] : tisTable_[kTisIntervals - 1];
    return p1 + 0.5 * f *
                    (p2 - p0 +
                     f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)));
}

bool AbgLobe::sample(const Vec2& beta0, double u1, double u2, Vec2& beta) const {
    const double outer = radialCdf(1.0 + std::min(1.0, glm::length(beta0)));
    return sampleWithRejection(u1, u2, [&](double a, double b) {
        const double r = inverseRadialCdf(a * outer);
        const double phi = 2.0 * kPi * b;
        const Vec2 candidate = beta0 + r * Vec2(std::cos(phi), std::sin(phi));
        if (!(glm::dot(candidate, candidate) < 1.0)) return false;
        beta = candidate;
        return true;
    });
}

AbgScatter::AbgScatter(std::optional<AbgParams> brdf, std::optional<AbgParams> btdf)
    : AbgScatter(brdf ? std::vector<AbgParams>{*brdf} : std::vector<AbgParams>{},
                 btdf ? std::vector<AbgParams>{*btdf} : std::vector<AbgParams>{}) {}

AbgScatter::AbgScatter(const std::vector<AbgParams>& brdf, const std::vector<AbgParams>& btdf) {
    if (brdf.empty() && btdf.empty())
        throw std::invalid_argument("ABg scatter needs a BRDF or a BTDF");
    double total = 0.0;
    for (const AbgParams& p : brdf) {
        reflect_.push_back(std::make_shared<const AbgLobe>(p));
        total += reflect_.back()->maxTis();
    }
    for (const AbgParams& p : btdf) {
        transmit_.push_back(std::make_shared<const AbgLobe>(p));
        total += transmit_.back()->maxTis();
    }
    if (total > 1.0)
        throw std::invalid_argument("ABg total integrated scatter reaches " +
                                    std::to_string(total) +
                                    " (BRDF and BTDF together must stay <= 1)");
}

double AbgScatter::tis(bool transmit, double b0) const {
    double sum = 0.0;
    for (const auto& l : lobes(transmit)) sum += l->tis(b0);
    return sum;
}

double AbgScatter::bsdf(bool transmit, double r) const {
    double sum = 0.0;
    for (const auto& l : lobes(transmit)) sum += l->bsdf(r);
    return sum;
}

bool AbgScatter::sample(bool transmit, const Vec2& beta0, double u1, double u2, Vec2& beta) const {
    const auto& ls = lobes(transmit);
    if (ls.size() == 1) return ls[0]->sample(beta0, u1, u2, beta);
    const double b0 = std::min(1.0, glm::length(beta0));
    const double total = tis(transmit, b0);
    if (!(total > 0.0)) return false;
    // The lobe by u1, and u1 stretched back to [0, 1) within it.
    double x = u1 * total;
    for (size_t k = 0; k < ls.size(); ++k) {
        const double t = ls[k]->tis(b0);
        if (x < t || k + 1 == ls.size()) {
            const double u = t > 0.0 ? std::clamp(x / t, 0.0, std::nextafter(1.0, 0.0)) : 0.0;
            return ls[k]->sample(beta0, u, u2, beta);
        }
        x -= t;
    }
    return false;
}

// Optical Property

OpticalProperty::OpticalProperty(std::string name, SpecularModel specular, ScatterModel scatter)
    : name_(std::move(name)), specular_(std::move(specular)), scatter_(std::move(scatter)) {
    try {
        std::visit(Overloaded{
                       [](const FixedSpecular& f) {
                           requireFraction(f.reflectance, "fixed reflectance");
                           requireFraction(f.transmittance, "fixed transmittance");
                           if (f.reflectance + f.transmittance > 1.0)
                               throw std::invalid_argument(
                                   "fixed reflectance + transmittance must be <= 1");
                       },
                       [](const QuarterWaveSpecular& q) {
                           if (!(q.index > 0.0) || !std::isfinite(q.index))
                               throw std::invalid_argument("coating index must be > 0");
                           if (!(q.designNm > 0.0) || !std::isfinite(q.designNm))
                               throw std::invalid_argument("design wavelength must be > 0");
                       },
                       [](const MirrorSpecular& m) {
                           requireFraction(m.reflectance, "mirror reflectance");
                       },
                       [](const auto&) {},
                   },
                   specular_);
        if (const auto* l = std::get_if<LambertianScatter>(&scatter_)) {
            requireFraction(l->reflectance, "Lambertian reflectance");
            requireFraction(l->transmittance, "Lambertian transmittance");
            if (l->reflectance + l->transmittance > 1.0)
                throw std::invalid_argument("Lambertian reflectance + transmittance must be <= 1");
        }
    } catch (const std::invalid_argument& e) {
        throw ModelError(name_, e.what());
    }
}

OpticalProperty OpticalProperty::uncoated(std::string name) {
    return OpticalProperty(std::move(name), FresnelSpecular{});
}
OpticalProperty OpticalProperty::idealAr(std::string name) {
    return OpticalProperty(std::move(name), IdealArSpecular{});
}
OpticalProperty OpticalProperty::absorber(std::string name) {
    return OpticalProperty(std::move(name), AbsorberSpecular{});
}
OpticalProperty OpticalProperty::mirror(double reflectance, std::string name) {
    return OpticalProperty(std::move(name), MirrorSpecular{reflectance});
}

namespace {

// Where the lobes of one side point, for one incident ray.
struct LobeFrame {
    bool transmit = false;
    Vec3 side{0.0};      // unit normal of the outgoing hemisphere
    Vec3 axis{0.0};      // specular direction on that side (mirror or Snell)
    bool valid = false;  // false: no such direction (TIR on the transmit side)
    Vec3 betaVec{0.0};   // projection of axis on the surface plane (beta0)
};

LobeFrame lobeFrame(const SurfaceContext& c, bool transmit) {
    LobeFrame f;
    f.transmit = transmit;
    f.side = transmit ? -c.normal : c.normal;
    const Vec3 tangential = c.direction - glm::dot(c.direction, c.normal) * c.normal;
    if (!transmit) {
        f.axis = reflect(c.direction, c.normal);
        f.betaVec = tangential;
        f.valid = true;
        return f;
    }
    if (const auto t = refract(c.direction, c.normal, c.n1, c.n2)) {
        f.axis = *t;
        f.betaVec = (c.n1 / c.n2) * tangential;
        f.valid = true;
    }
    return f;
}

// The K-correlation lobe of one side for an incident ray (f its frame: for the BTDF, the
// refracted direction's cosine).
KcLobe kcLobe(const KCorrelationScatter& k, const SurfaceContext& c, const LobeFrame& f) {
    if (!f.transmit) return k.reflectLobe(c.wavelengthNm, c.n1, c.cosIncidence());
    return k.transmitLobe(c.wavelengthNm, c.n1, c.n2, c.cosIncidence(),
                          std::abs(glm::dot(f.axis, c.normal)));
}

// The frame of a tabulated lobe: the specular angle (degrees) and the unit vectors u (toward
// the side's normal, azimuth 0) and v = s x u about the specular direction s.
struct TableFrame {
    double thetaDeg = 0.0;
    Vec3 u{0.0}, v{0.0};
};
// The specular direction's angle from the side's normal, degrees.
double specularAngleDeg(const LobeFrame& f) {
    return std::acos(std::clamp(glm::dot(f.axis, f.side), -1.0, 1.0)) / kDeg;
}
TableFrame tableFrame(const LobeFrame& f) {
    TableFrame t;
    const double c = std::clamp(glm::dot(f.axis, f.side), -1.0, 1.0);
    t.thetaDeg = specularAngleDeg(f);
    Vec3 u = f.side - c * f.axis;
    const double len = glm::length(u);
    if (len > 1e-12) {
        u /= len;
    } else {
        Vec3 t2;
        basisAround(f.axis, u, t2);
    }
    t.u = u;
    t.v = glm::cross(f.axis, u);
    return t;
}
// Radial angle and azimuth of `out` about the specular direction.
void tableAngles(const LobeFrame& f, const TableFrame& t, const Vec3& out, double& r, double& phi) {
    r = std::acos(std::clamp(glm::dot(out, f.axis), -1.0, 1.0));
    phi = std::atan2(glm::dot(out, t.v), glm::dot(out, t.u));
    if (phi < 0.0) phi += 2.0 * kPi;
}

}  // namespace

namespace {

// The specular model's reflected and transmitted shares of the light left to it (1).
struct SpecularShares {
    double r = 0.0, t = 0.0;
    bool tir = false;
};
SpecularShares specularShares(const SpecularModel& model, const SurfaceContext& c, bool tir) {
    const double cosI = c.cosIncidence();
    SpecularShares s;
    std::visit(Overloaded{
                   [&](const FresnelSpecular&) {
                       s.r = tir ? 1.0 : fresnelReflectance(c.n1, c.n2, cosI);
                       s.t = 1.0 - s.r;
                       s.tir = tir;
                   },
                   [&](const IdealArSpecular&) {
                       s.r = tir ? 1.0 : 0.0;
                       s.t = 1.0 - s.r;
                       s.tir = tir;
                   },
                   [&](const FixedSpecular& f) {
                       s.r = tir ? f.reflectance + f.transmittance : f.reflectance;
                       s.t = tir ? 0.0 : f.transmittance;
                       s.tir = tir;
                   },
                   [&](const QuarterWaveSpecular& q) {
                       s.r = tir ? 1.0
                                 : quarterWaveCoating(c.n1, q.index, q.designNm, c.n2, cosI,
                                                      c.wavelengthNm)
                                       .reflectance();
                       s.t = 1.0 - s.r;
                       s.tir = tir;
                   },
                   [&](const MirrorSpecular& m) { s.r = m.reflectance; },
                   [&](const AbsorberSpecular&) {},
               },
               model);
    if (c.opaque) s.t = 0.0;
    return s;
}

// Where the light meets the dust of a particulate model (tracer/surfaces/particulate.h): the dust
// sits in the lower-index medium. Light from that side meets it before the surface; light from the
// dense side meets it after refracting out (none under total internal reflection). Scattered
// directions toward the light's side (dot(d, c.normal) > 0: the reflect channel) and away from it
// (the transmit channel) are in the dust's medium on its side and refracted into the dense medium
// on the other.
struct DustFrame {
    bool valid = false;
    bool lightFromLow = true;
    Vec3 incoming{0.0};  // the light's direction in the dust's medium
    double cosLow = 1.0, nLow = 1.0, nHigh = 1.0;
    double fExt = 0.0;       // share of the light reaching the dust that it intercepts
    double scattered = 0.0;  // share of the incident light the dust scatters
    double back = 0.0;       // of that, the share toward the light's side
    // On an opaque surface that reflects (r > 0): the dust's forward light the substrate
    // reflects, and the reflected beam's forward scatter on its way out, both a lobe about
    // the mirror direction: r (2 - f_ext) scattered (1 - back) of the incident light.
    Vec3 mirrored{0.0};
    double image = 0.0;
    // The substrate takes no light in (opaque, or a mirror or absorbing coating): the dust's
    // forward light does not cross it.
    bool sealed = false;
    const ParticulateEnsemble* dust = nullptr;  // owned by the model's cache

    // Whether a channel's directions lie in the dust's medium (no refraction).
    bool direct(bool transmit) const { return transmit != lightFromLow; }
    double tis(bool transmit) const {
        if (transmit) return sealed ? 0.0 : scattered * (1.0 - back);
        return scattered * back + image;
    }
};

DustFrame dustFrame(const ParticulateScatter& ps, const SurfaceContext& c, double specularR,
                    double specularT, bool tir) {
    DustFrame f;
    if (c.opaque || c.n1 <= c.n2) {
        f.lightFromLow = true;
        f.incoming = c.direction;
        f.cosLow = c.cosIncidence();
        f.nLow = c.n1;
        f.nHigh = c.opaque ? c.n1 : c.n2;
    } else {
        if (tir) return f;
        const auto t = refract(c.direction, c.normal, c.n1, c.n2);
        if (!t) return f;
        f.lightFromLow = false;
        f.incoming = *t;
        f.cosLow = std::clamp(-glm::dot(*t, c.normal), 0.0, 1.0);
        f.nLow = c.n2;
        f.nHigh = c.n1;
    }
    f.dust = ps.at(c.wavelengthNm, f.nLow);
    f.fExt = f.cosLow > 0.0 ? -std::expm1(-f.dust->extinction() / f.cosLow) : 1.0;
    f.scattered = (f.lightFromLow ? 1.0 : specularT) * f.fExt * f.dust->albedo();
    f.back = f.dust->backShare(f.cosLow);
    f.sealed = f.lightFromLow && (c.opaque || !(specularT > 0.0));
    if (f.sealed && specularR > 0.0) {
        f.mirrored = reflect(c.direction, c.normal);
        f.image = specularR * (2.0 - f.fExt) * f.scattered * (1.0 - f.back);
    }
    f.valid = true;
    return f;
}

// The dust's BSDF at `out` for the channel out lies in (0 where it cannot reach).
double dustBsdf(const DustFrame& f, const SurfaceContext& c, const Vec3& out, bool transmit) {
    if (transmit && f.sealed) return 0.0;
    Vec3 low = out;
    if (!f.direct(transmit)) {
        // The direction in the dust's medium that refracts into out.
        const Vec3 highSide = f.lightFromLow ? -c.normal : c.normal;
        const auto back = refract(-out, highSide, f.nHigh, f.nLow);
        if (!back) return 0.0;
        low = -*back;
    }
    const double cosLow = std::abs(glm::dot(low, c.normal));
    if (!(cosLow > 0.0)) return 0.0;
    double v = f.scattered * f.dust->phase(glm::dot(f.incoming, low)) / cosLow;
    if (f.image > 0.0 && !transmit && f.back < 1.0)
        v += f.image / (1.0 - f.back) * f.dust->phase(glm::dot(f.mirrored, low)) / cosLow;
    const double ratio = f.nHigh / f.nLow;
    return f.direct(transmit) ? v : ratio * ratio * v;
}

}  // namespace

Channels OpticalProperty::channels(const SurfaceContext& c) const {
    const double cosI = c.cosIncidence();
    const bool tir = !c.opaque && totalInternalReflection(c.n1, c.n2, cosI);
    Channels ch;

    // Scatter first.
    double sR = 0.0, sT = 0.0;
    std::visit(Overloaded{
                   [&](const NoScatter&) {},
                   [&](const LambertianScatter& l) {
                       sR = l.reflectance;
                       sT = l.transmittance;
                   },
                   [&](const GaussianScatter& g) {
                       sR = g.reflectance();
                       sT = tir ? 0.0 : g.transmittance();
                   },
                   [&](const AbgScatter& a) {
                       const double b0 = std::sqrt(std::max(0.0, 1.0 - cosI * cosI));
                       sR = a.tis(false, b0);
                       if (!tir) sT = a.tis(true, std::min(1.0, c.n1 / c.n2 * b0));
                   },
                   [&](const KCorrelationScatter& k) {
                       if (k.reflects()) sR = k.tis(k.reflectLobe(c.wavelengthNm, c.n1, cosI));
                       if (k.transmits() && !tir && !c.opaque) {
                           const LobeFrame f = lobeFrame(c, true);
                           if (f.valid) sT = k.tis(kcLobe(k, c, f));
                       }
                       // Past the smooth-surface limit (PropertyTable::checkScatterEnergy
                       // refuses such scenes) the transmitted share is cut to what is left.
                       sT = std::min(sT, std::max(0.0, 1.0 - sR));
                   },
                   [&](const ParticulateScatter&) {},  // below, with the specular part
                   [&](const TabulatedScatter& t) {
                       // The specular angle: the incidence for the BRDF, the refraction
                       // angle for the BTDF.
                       if (t.reflectLobe()) sR = t.reflectLobe()->tis(std::acos(cosI) / kDeg);
                       if (t.transmitLobe() && !tir && !c.opaque) {
                           const LobeFrame f = lobeFrame(c, true);
                           if (f.valid) sT = t.transmitLobe()->tis(specularAngleDeg(f));
                       }
                       sT = std::min(sT, std::max(0.0, 1.0 - sR));
                   },
               },
               scatter_);
    if (c.opaque) sT = 0.0;
    ch.scatterReflect = sR;
    ch.scatterTransmit = sT;
    const double rest = std::max(0.0, 1.0 - sR - sT);

    // The specular part shares the rest.
    const SpecularShares spec = specularShares(specular_, c, tir);
    ch.tir = spec.tir;
    if (const auto* ps = std::get_if<ParticulateScatter>(&scatter_)) {
        const DustFrame f = dustFrame(*ps, c, spec.r, spec.t, tir);
        if (!f.valid) {
            ch.specularReflect = spec.r;
            ch.specularTransmit = spec.t;
            return ch;
        }
        // Light from the dust's side passes it before the surface (both specular parts
        // lose f_ext); from the dense side only the transmitted light meets it.
        // On a sealed substrate (a mirror) the reflected beam crosses the dust again on its
        // way out.
        ch.specularReflect = !f.lightFromLow ? spec.r
                             : f.sealed      ? (1.0 - f.fExt) * (1.0 - f.fExt) * spec.r
                                             : (1.0 - f.fExt) * spec.r;
        ch.specularTransmit = (1.0 - f.fExt) * spec.t;
        ch.scatterReflect = f.tis(false);
        ch.scatterTransmit = f.tis(true);
        return ch;
    }
    const double r = spec.r, t = spec.t;
    ch.specularReflect = rest * r;
    ch.specularTransmit = rest * t;
    return ch;
}

ScatterSample OpticalProperty::sampleScatter(const SurfaceContext& c, bool transmit, double u1,
                                             double u2) const {
    if (transmit && c.opaque) return {};
    return std::visit(
        Overloaded{
            [&](const NoScatter&) { return ScatterSample{}; },
            [&](const LambertianScatter& l) {
                if ((transmit ? l.transmittance : l.reflectance) <= 0.0) return ScatterSample{};
                const Vec3 side = transmit ? -c.normal : c.normal;
                Vec3 t1, t2;
                basisAround(side, t1, t2);
                const double r = std::sqrt(u1), phi = 2.0 * kPi * u2;
                const double z = std::sqrt(std::max(0.0, 1.0 - u1));
                const Vec3 d = r * std::cos(phi) * t1 + r * std::sin(phi) * t2 + z * side;
                return ScatterSample{d, z / kPi};
            },
            [&](const GaussianScatter& g) {
                if ((transmit ? g.transmittance() : g.reflectance()) <= 0.0) return ScatterSample{};
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return ScatterSample{};
                return g.sample(f.axis, f.side, u1, u2);
            },
            [&](const AbgScatter& a) {
                if (!a.has(transmit)) return ScatterSample{};
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return ScatterSample{};
                Vec3 t1, t2;
                basisAround(f.side, t1, t2);
                const Vec2 beta0(glm::dot(f.betaVec, t1), glm::dot(f.betaVec, t2));
                const double tis = a.tis(transmit, glm::length(beta0));
                if (!(tis > 0.0)) return ScatterSample{};
                Vec2 beta;
                if (!a.sample(transmit, beta0, u1, u2, beta)) return ScatterSample{f.axis, 0.0};
                const double cosO = std::sqrt(std::max(0.0, 1.0 - glm::dot(beta, beta)));
                const Vec3 d = glm::normalize(beta.x * t1 + beta.y * t2 + cosO * f.side);
                return ScatterSample{d, a.bsdf(transmit, glm::length(beta - beta0)) * cosO / tis};
            },
            [&](const KCorrelationScatter& k) {
                if (!(transmit ? k.transmits() : k.reflects())) return ScatterSample{};
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return ScatterSample{};
                const KcLobe lobe = kcLobe(k, c, f);
                const double tis = k.tis(lobe);
                if (!(tis > 0.0)) return ScatterSample{};
                Vec3 t1, t2;
                basisAround(f.side, t1, t2);
                const Vec2 beta0(glm::dot(f.betaVec, t1), glm::dot(f.betaVec, t2));
                Vec2 beta;
                if (!k.sample(lobe, beta0, u1, u2, beta)) return ScatterSample{f.axis, 0.0};
                const double cosO = std::sqrt(std::max(0.0, 1.0 - glm::dot(beta, beta)));
                const Vec3 d = glm::normalize(beta.x * t1 + beta.y * t2 + cosO * f.side);
                return ScatterSample{d, k.bsdf(lobe, glm::length(beta - beta0), cosO) * cosO / tis};
            },
            [&](const ParticulateScatter& ps) {
                const bool tir = !c.opaque && totalInternalReflection(c.n1, c.n2, c.cosIncidence());
                const SpecularShares sp = specularShares(specular_, c, tir);
                const DustFrame f = dustFrame(ps, c, sp.r, sp.t, tir);
                if (!f.valid) return ScatterSample{};
                const double tis = f.tis(transmit);
                if (!(tis > 0.0)) return ScatterSample{};
                // The lobe (about the light's direction, or the mirrored one for the image
                // light) in proportion to its share, then directions of the phase function
                // about it until one lies on the channel's side.
                Vec3 axis = f.incoming;
                const double imageShare = transmit ? 0.0 : f.image / tis;
                if (u1 < imageShare) {
                    axis = f.mirrored;
                    u1 /= imageShare;
                } else if (imageShare > 0.0) {
                    u1 = std::min(1.0, (u1 - imageShare) / (1.0 - imageShare));
                }
                Vec3 low(0.0);
                const ParticulateEnsemble::SideSampler side(*f.dust, axis, c.normal, !transmit);
                const bool ok = sampleWithRejection(
                    u1, u2, [&](double a, double b) { return side.attempt(a, b, low); }, 1 << 16);
                if (!ok) return ScatterSample{f.incoming, 0.0};
                Vec3 out = low;
                if (!f.direct(transmit)) {
                    const auto r =
                        refract(low, f.lightFromLow ? c.normal : -c.normal, f.nLow, f.nHigh);
                    if (!r) return ScatterSample{low, 0.0};
                    out = *r;
                }
                return ScatterSample{
                    out, dustBsdf(f, c, out, transmit) * std::abs(glm::dot(out, c.normal)) / tis};
            },
            [&](const TabulatedScatter& t) {
                const TabulatedLobe* lobe = transmit ? t.transmitLobe() : t.reflectLobe();
                if (!lobe) return ScatterSample{};
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return ScatterSample{};
                const TableFrame tf = tableFrame(f);
                const double tis = lobe->tis(tf.thetaDeg);
                if (!(tis > 0.0)) return ScatterSample{};
                double r = 0.0, phi = 0.0;
                if (!lobe->sample(tf.thetaDeg, u1, u2, r, phi)) return ScatterSample{f.axis, 0.0};
                const Vec3 d =
                    glm::normalize(std::cos(r) * f.axis +
                                   std::sin(r) * (std::cos(phi) * tf.u + std::sin(phi) * tf.v));
                const double cosO = std::abs(glm::dot(d, f.side));
                return ScatterSample{d, lobe->bsdf(tf.thetaDeg, r, phi) * cosO / tis};
            },
        },
        scatter_);
}

double OpticalProperty::bsdf(const SurfaceContext& c, const Vec3& out) const {
    const double cosO = glm::dot(out, c.normal);
    if (cosO == 0.0) return 0.0;
    const bool transmit = cosO < 0.0;
    if (transmit && c.opaque) return 0.0;
    return std::visit(
        Overloaded{
            [&](const NoScatter&) { return 0.0; },
            [&](const LambertianScatter& l) {
                return (transmit ? l.transmittance : l.reflectance) / kPi;
            },
            [&](const GaussianScatter& g) {
                const double frac = transmit ? g.transmittance() : g.reflectance();
                if (frac <= 0.0) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return 0.0;
                return frac * g.pdf(f.axis, f.side, out) / std::abs(cosO);
            },
            [&](const AbgScatter& a) {
                if (!a.has(transmit)) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return 0.0;
                const Vec3 beta = out - glm::dot(out, c.normal) * c.normal;
                return a.bsdf(transmit, glm::length(beta - f.betaVec));
            },
            [&](const KCorrelationScatter& k) {
                if (!(transmit ? k.transmits() : k.reflects())) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return 0.0;
                const Vec3 beta = out - glm::dot(out, c.normal) * c.normal;
                return k.bsdf(kcLobe(k, c, f), glm::length(beta - f.betaVec), std::abs(cosO));
            },
            [&](const TabulatedScatter& t) {
                const TabulatedLobe* lobe = transmit ? t.transmitLobe() : t.reflectLobe();
                if (!lobe) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return 0.0;
                const TableFrame tf = tableFrame(f);
                double r = 0.0, phi = 0.0;
                tableAngles(f, tf, out, r, phi);
                return lobe->bsdf(tf.thetaDeg, r, phi);
            },
            [&](const ParticulateScatter& ps) {
                const bool tir = !c.opaque && totalInternalReflection(c.n1, c.n2, c.cosIncidence());
                const SpecularShares sp = specularShares(specular_, c, tir);
                const DustFrame f = dustFrame(ps, c, sp.r, sp.t, tir);
                return f.valid ? dustBsdf(f, c, out, transmit) : 0.0;
            },
        },
        scatter_);
}

double OpticalProperty::scatterPdf(const SurfaceContext& c, const Vec3& out) const {
    const double cosO = glm::dot(out, c.normal);
    if (cosO == 0.0) return 0.0;
    const bool transmit = cosO < 0.0;
    if (transmit && c.opaque) return 0.0;
    return std::visit(
        Overloaded{
            [&](const NoScatter&) { return 0.0; },
            [&](const LambertianScatter& l) {
                return (transmit ? l.transmittance : l.reflectance) > 0.0 ? std::abs(cosO) / kPi
                                                                          : 0.0;
            },
            [&](const GaussianScatter& g) {
                if ((transmit ? g.transmittance() : g.reflectance()) <= 0.0) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                return f.valid ? g.pdf(f.axis, f.side, out) : 0.0;
            },
            [&](const AbgScatter& a) {
                if (!a.has(transmit)) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return 0.0;
                const double tis = a.tis(transmit, glm::length(f.betaVec));
                const Vec3 beta = out - glm::dot(out, c.normal) * c.normal;
                return tis > 0.0
                           ? a.bsdf(transmit, glm::length(beta - f.betaVec)) * std::abs(cosO) / tis
                           : 0.0;
            },
            [&](const KCorrelationScatter& k) {
                if (!(transmit ? k.transmits() : k.reflects())) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return 0.0;
                const KcLobe lobe = kcLobe(k, c, f);
                const double tis = k.tis(lobe);
                const Vec3 beta = out - glm::dot(out, c.normal) * c.normal;
                return tis > 0.0 ? k.bsdf(lobe, glm::length(beta - f.betaVec), std::abs(cosO)) *
                                       std::abs(cosO) / tis
                                 : 0.0;
            },
            [&](const TabulatedScatter& t) {
                const TabulatedLobe* lobe = transmit ? t.transmitLobe() : t.reflectLobe();
                if (!lobe) return 0.0;
                const LobeFrame f = lobeFrame(c, transmit);
                if (!f.valid) return 0.0;
                const TableFrame tf = tableFrame(f);
                const double tis = lobe->tis(tf.thetaDeg);
                if (!(tis > 0.0)) return 0.0;
                double r = 0.0, phi = 0.0;
                tableAngles(f, tf, out, r, phi);
                return lobe->bsdf(tf.thetaDeg, r, phi) * std::abs(cosO) / tis;
            },
            [&](const ParticulateScatter& ps) {
                const bool tir = !c.opaque && totalInternalReflection(c.n1, c.n2, c.cosIncidence());
                const SpecularShares sp = specularShares(specular_, c, tir);
                const DustFrame f = dustFrame(ps, c, sp.r, sp.t, tir);
                if (!f.valid) return 0.0;
                const double tis = f.tis(transmit);
                return tis > 0.0 ? dustBsdf(f, c, out, transmit) * std::abs(cosO) / tis : 0.0;
            },
        },
        scatter_);
}

// Transport Modes

std::ostream& operator<<(std::ostream& os, TransportMode m) {
    return os << (m == TransportMode::Flux ? "flux" : "importance");
}

SurfaceContext reverseContext(const SurfaceContext& c, const Vec3& out) {
    SurfaceContext r = c;
    r.direction = -out;
    if (glm::dot(out, c.normal) < 0.0) {  // across the surface: the light comes from there
        r.normal = -c.normal;
        r.n1 = c.n2;
        r.n2 = c.n1;
    }
    return r;
}

double OpticalProperty::bsdf(const SurfaceContext& c, const Vec3& out, TransportMode mode) const {
    if (mode == TransportMode::Flux) return bsdf(c, out);
    return bsdf(reverseContext(c, out), -c.direction);
}

double OpticalProperty::specularReflectWeight(const SurfaceContext& c, TransportMode mode) const {
    if (mode == TransportMode::Flux) return channels(c).specularReflect;
    return channels(reverseContext(c, reflect(c.direction, c.normal))).specularReflect;
}

double OpticalProperty::specularTransmitWeight(const SurfaceContext& c, TransportMode mode) const {
    if (mode == TransportMode::Flux) return channels(c).specularTransmit;
    if (c.opaque) return 0.0;
    const std::optional<Vec3> t = refract(c.direction, c.normal, c.n1, c.n2);
    if (!t) return 0.0;
    const double ratio = c.n1 / c.n2;
    return channels(reverseContext(c, *t)).specularTransmit * ratio * ratio;
}

std::ostream& operator<<(std::ostream& os, const OpticalProperty& p) {
    return os << "OpticalProperty{'" << p.name() << "', specular " << p.specular() << ", scatter "
              << p.scatter() << "}";
}

}  // namespace veil
