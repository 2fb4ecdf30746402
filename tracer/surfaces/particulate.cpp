#include "tracer/surfaces/particulate.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "geometry/numerics.h"
#include "tracer/surfaces/mie.h"

namespace veil {

namespace {

constexpr int kAngleSteps = 1500;      // theta_k = pi (k / kAngleSteps)^2
constexpr int kBinsPerOctave = 12;     // of particle diameter
constexpr int kBackSteps = 1200;       // the backShare table: uniform in cos(incidence)
constexpr double kUm2Per0p1M2 = 1e11;  // 0.1 m^2 in um^2

// Fraction of a circle of angular radius alpha about an axis at angle thetaS from n that lies
// in the open hemisphere about n.
double circleFractionAbove(double cosAlpha, double sinAlpha, double cosS, double sinS) {
    if (sinAlpha <= 0.0 || sinS <= 0.0) return cosAlpha * cosS > 0.0 ? 1.0 : 0.0;
    const double c = -cosAlpha * cosS / (sinAlpha * sinS);
    return std::acos(std::clamp(c, -1.0, 1.0)) / kPi;
}

std::string number(double v) {
    std::string s = std::to_string(v);
    s.erase(s.find_last_not_of('0') + 1);
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
}

}  // namespace

std::ostream& operator<<(std::ostream& os, const ParticulateParams& p) {
    return os << "particulate{level " << p.level << ", " << p.minUm << " um up, index " << p.index
              << " + " << p.k << "i}";
}

double cc1246Count(double level, double dUm) {
    if (!(dUm <= level)) return 0.0;
    const double a = std::log10(level), b = std::log10(dUm);
    return std::pow(10.0, 0.926 * (a * a - b * b));
}

double cc1246Pac(double level) {
    const double a = std::log10(level);
    return std::pow(10.0, -7.245 + 0.926 * a * a);
}

// Particulate Ensemble

ParticulateEnsemble::ParticulateEnsemble(const ParticulateParams& p, double wavelengthUm,
                                         double mediumIndex) {
    if (!(wavelengthUm > 0.0) || !(mediumIndex > 0.0))
        throw std::invalid_argument("particulate ensemble needs a wavelength and a medium index");
    // The nodes: theta_k = pi (k / K)^2, stored by ascending mu.
    std::vector<double> muDescending(kAngleSteps + 1);
    for (int k = 0; k <= kAngleSteps; ++k) {
        const double t = static_cast<double>(k) / kAngleSteps;
        muDescending[static_cast<size_t>(k)] = std::cos(kPi * t * t);
    }
    muDescending.back() = -1.0;
    std::vector<double> sigma(muDescending.size(), 0.0);  // sum of N dsigma/dOmega (um^2/sr)

    const std::complex<double> m(p.index / mediumIndex, p.k / mediumIndex);
    const double wavenumber = 2.0 * kPi / wavelengthUm;
    const double octaves = std::log2(p.level / p.minUm);
    const int bins = std::max(4, static_cast<int>(std::ceil(kBinsPerOctave * octaves)));
    std::vector<double> intensity;
    auto add = [&](double diameterUm, double perUm2) {
        if (!(perUm2 > 0.0)) return;
        const double x = kPi * diameterUm / wavelengthUm;
        const MieEfficiencies e = mieScatter(x, m, muDescending, &intensity);
        const double area = 0.25 * kPi * diameterUm * diameterUm;
        cExt_ += perUm2 * e.qext * area;
        cSca_ += perUm2 * e.qsca * area;
        cGeo_ += perUm2 * area;
        for (size_t k = 0; k < sigma.size(); ++k)
            sigma[k] += perUm2 * intensity[k] / (wavenumber * wavenumber);
    };
    for (int j = 0; j < bins; ++j) {
        const double d0 = p.minUm * std::pow(p.level / p.minUm, static_cast<double>(j) / bins);
        const double d1 = p.minUm * std::pow(p.level / p.minUm, static_cast<double>(j + 1) / bins);
        add(std::sqrt(d0 * d1),
            (cc1246Count(p.level, d0) - cc1246Count(p.level, d1)) / kUm2Per0p1M2);
    }
    add(p.level, cc1246Count(p.level, p.level) / kUm2Per0p1M2);  // the one of size L

    mu_.assign(muDescending.rbegin(), muDescending.rend());
    p_.assign(sigma.rbegin(), sigma.rend());
    // Normalised so that the interpolant (linear in mu) integrates to 1 over the sphere.
    cdf_.assign(mu_.size(), 0.0);
    for (size_t k = 1; k < mu_.size(); ++k)
        cdf_[k] = cdf_[k - 1] + kPi * (p_[k - 1] + p_[k]) * (mu_[k] - mu_[k - 1]);
    const double total = cdf_.back();
    if (!(total > 0.0)) throw std::invalid_argument("particulate ensemble scatters nothing");
    for (double& v : p_) v /= total;
    for (double& v : cdf_) v /= total;
    cdf_.back() = 1.0;
    guide_.resize(static_cast<size_t>(kGuideBuckets) + 1);
    for (int g = 0; g <= kGuideBuckets; ++g) {
        const double threshold = static_cast<double>(g) / kGuideBuckets;
        guide_[static_cast<size_t>(g)] = static_cast<uint32_t>(
            std::upper_bound(cdf_.begin(), cdf_.end(), threshold) - cdf_.begin());
    }

    back_.resize(static_cast<size_t>(kBackSteps) + 1);
    for (int i = 0; i <= kBackSteps; ++i)
        back_[static_cast<size_t>(i)] = backShareExact(static_cast<double>(i) / kBackSteps);
}

double ParticulateEnsemble::phase(double mu) const {
    mu = std::clamp(mu, -1.0, 1.0);
    const auto it = std::upper_bound(mu_.begin(), mu_.end(), mu);
    if (it == mu_.end()) return p_.back();
    const size_t k = static_cast<size_t>(it - mu_.begin());
    if (k == 0) return p_.front();
    const double t = (mu - mu_[k - 1]) / (mu_[k] - mu_[k - 1]);
    return p_[k - 1] + t * (p_[k] - p_[k - 1]);
}

double ParticulateEnsemble::backShareExact(double cosIn) const {
    cosIn = std::clamp(cosIn, 0.0, 1.0);
    const double sinIn = std::sqrt(1.0 - cosIn * cosIn);
    // Four-point Gauss-Legendre on every interval of the table.
    static const double xs[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                                 0.8611363115940526};
    static const double ws[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                                 0.3478548451374538};
    double sum = 0.0;
    for (size_t k = 1; k < mu_.size(); ++k) {
        const double a = mu_[k - 1], b = mu_[k], half = 0.5 * (b - a);
        for (int q = 0; q < 4; ++q) {
            const double t = 0.5 * (1.0 + xs[q]);
            const double mu = a + t * (b - a);
            const double pv = p_[k - 1] + t * (p_[k] - p_[k - 1]);
            const double sinA = std::sqrt(std::max(0.0, 1.0 - mu * mu));
            sum += ws[q] * half * pv * circleFractionAbove(mu, sinA, -cosIn, sinIn);
        }
    }
    return std::clamp(2.0 * kPi * sum, 0.0, 1.0);
}

double ParticulateEnsemble::backShare(double cosIn) const {
    // Uniform in cos: fine near grazing, where the forward peak crosses the surface's plane,
    // and the share is linear in cos near the normal.
    const double s = std::clamp(cosIn, 0.0, 1.0) * kBackSteps;
    const size_t i = std::min(back_.size() - 2, static_cast<size_t>(s));
    const double t = std::clamp(s - static_cast<double>(i), 0.0, 1.0);
    return back_[i] + t * (back_[i + 1] - back_[i]);
}

double ParticulateEnsemble::sampleMu(double u) const {
    u = std::clamp(u, 0.0, 1.0);
    // The first node whose cdf exceeds u (std::upper_bound over all of cdf_), searched between
    // the guide entries a bucket either side of u's: the answer lies between those of u's own
    // bucket, and the margin covers the rounding of u * kGuideBuckets.
    const int g = static_cast<int>(u * kGuideBuckets);
    const size_t lo = guide_[static_cast<size_t>(std::max(g - 1, 0))];
    const size_t hi = std::min(
        cdf_.size(), size_t{guide_[static_cast<size_t>(std::min(g + 2, kGuideBuckets))]} + 1);
    const auto it = std::upper_bound(cdf_.begin() + lo, cdf_.begin() + hi, u);
    const size_t k = std::clamp<size_t>(static_cast<size_t>(it - cdf_.begin()), 1, cdf_.size() - 1);
    const double a = mu_[k - 1], width = mu_[k] - a;
    const double pa = p_[k - 1], pb = p_[k];
    // The interval's mass up to t: 2 pi width (pa t + (pb - pa) t^2 / 2) = u - cdf(a).
    const double r = std::max(0.0, u - cdf_[k - 1]) / (2.0 * kPi * width);
    const double disc = std::max(0.0, pa * pa + 2.0 * (pb - pa) * r);
    const double denom = pa + std::sqrt(disc);
    const double t = denom > 0.0 ? std::clamp(2.0 * r / denom, 0.0, 1.0) : 0.5;
    return a + t * width;
}

namespace {

// The frame sample() draws about, and its direction for polar cosine mu and azimuth u2.
void frameAbout(const Vec3& incoming, Vec3& t1, Vec3& t2) {
    const Vec3 helper = std::abs(incoming.x) < 0.6 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    t1 = glm::normalize(glm::cross(incoming, helper));
    t2 = glm::cross(incoming, t1);
}
Vec3 directionAbout(const Vec3& incoming, const Vec3& t1, const Vec3& t2, double mu, double s,
                    double u2) {
    const double phi = 2.0 * kPi * u2;
    return glm::normalize(mu * incoming + s * (std::cos(phi) * t1 + std::sin(phi) * t2));
}

// A try is refused early only when the best azimuth misses the side by this much: the frame
// is orthonormal to rounding, far inside it.
constexpr double kSideMargin = 1e-9;

}  // namespace

Vec3 ParticulateEnsemble::sample(const Vec3& incoming, double u1, double u2) const {
    const double mu = sampleMu(u1);
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    Vec3 t1, t2;
    frameAbout(incoming, t1, t2);
    return directionAbout(incoming, t1, t2, mu, s, u2);
}

ParticulateEnsemble::SideSampler::SideSampler(const ParticulateEnsemble& e, const Vec3& incoming,
                                              const Vec3& normal, bool above)
    : e_(e), incoming_(incoming), normal_(normal), above_(above) {
    frameAbout(incoming, t1_, t2_);
    along_ = glm::dot(incoming, normal);
    across_ = std::hypot(glm::dot(t1_, normal), glm::dot(t2_, normal));
}

bool ParticulateEnsemble::SideSampler::attempt(double u1, double u2, Vec3& out) const {
    const double mu = e_.sampleMu(u1);
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    // Over all azimuths the direction's height above the plane spans
    // mu along -+ s across (before normalisation, which keeps its sign).
    if (above_ ? mu * along_ + s * across_ < -kSideMargin : mu * along_ - s * across_ > kSideMargin)
        return false;
    out = directionAbout(incoming_, t1_, t2_, mu, s, u2);
    const double side = glm::dot(out, normal_);
    return above_ ? side > 0.0 : side < 0.0;
}

// Particulate Scatter

ParticulateScatter::ParticulateScatter(const ParticulateParams& p)
    : p_(p), cache_(std::make_shared<Cache>()) {
    // Past level 1000 the particles cover more than 11 % of the surface (1000: 11.4 %, 1500:
    // 80 %): no longer sparse dust that scatters once.
    if (!(p.level >= 1.0 && p.level <= 1000.0))
        throw std::invalid_argument("level must be in [1, 1000] (got " + number(p.level) +
                                    "): beyond 1000 the particles cover more than 11 % of the "
                                    "surface, past the single-scatter model");
    if (!(p.minUm >= 1.0 && p.minUm < p.level))
        throw std::invalid_argument(
            "min_um must be at least 1 (the distribution's range) and "
            "below the level " +
            number(p.level) + " (got " + number(p.minUm) + ")");
    if (!(p.index > 0.0 && p.index < 10.0))
        throw std::invalid_argument("index must be in (0, 10) (got " + number(p.index) + ")");
    if (!(p.k >= 0.0 && p.k < 10.0))
        throw std::invalid_argument("k must be in [0, 10) (got " + number(p.k) + ")");
}

const ParticulateEnsemble* ParticulateScatter::Cache::find(double wavelengthNm,
                                                           double mediumIndex) const {
    for (const Entry* e = newest.load(std::memory_order_acquire); e; e = e->next)
        if (e->wavelengthNm == wavelengthNm && e->mediumIndex == mediumIndex)
            return e->ensemble.get();
    return nullptr;
}

const ParticulateEnsemble* ParticulateScatter::at(double wavelengthNm, double mediumIndex) const {
    if (const ParticulateEnsemble* e = cache_->find(wavelengthNm, mediumIndex)) return e;
    std::lock_guard lock(cache_->writing);
    if (const ParticulateEnsemble* e = cache_->find(wavelengthNm, mediumIndex)) return e;
    const Entry* entry = cache_->owned
                             .emplace_back(std::make_unique<const Entry>(
                                 Entry{wavelengthNm, mediumIndex,
                                       std::make_unique<const ParticulateEnsemble>(
                                           p_, wavelengthNm * 1e-3 / mediumIndex, mediumIndex),
                                       cache_->newest.load(std::memory_order_relaxed)}))
                             .get();
    cache_->newest.store(entry, std::memory_order_release);
    return entry->ensemble.get();
}

}  // namespace veil
