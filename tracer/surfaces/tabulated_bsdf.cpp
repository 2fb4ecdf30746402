#include "tracer/surfaces/tabulated_bsdf.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <sstream>

#include "geometry/numerics.h"
#include "lensdata/zemax_bsdf.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/lobe_math.h"

namespace veil {

namespace {

constexpr double kDeg = kPi / 180.0;
constexpr double kTisStepDeg = 0.25;
constexpr int kTisSteps = 360;  // 0 to 90 degrees
constexpr int kMaxTries = 4096;

// cos of the scattered direction's angle from the normal, for specular angle theta:
// s = (sin theta, 0, cos theta), u = (-cos theta, 0, sin theta), v = (0, 1, 0).
double cosFromNormal(double cosT, double sinT, double r, double phi) {
    return std::cos(r) * cosT + std::sin(r) * std::cos(phi) * sinT;
}

}  // namespace

TabulatedLobe::TabulatedLobe(const ZemaxBsdf& data, bool scaleToFileTis)
    : source_(data.source), transmission_(data.transmission), scaled_(scaleToFileTis) {
    const size_t nAz = data.azimuthDeg.size(), nRad = data.radialDeg.size();
    // Azimuths over the whole circle: PlaneSymmetrical rows mirrored (phi -> 360 - phi).
    std::vector<int> rowOf;
    for (size_t a = 0; a < nAz; ++a) {
        azRad_.push_back(data.azimuthDeg[a] * kDeg);
        rowOf.push_back(static_cast<int>(a));
    }
    if (data.planeSymmetric)
        for (int a = static_cast<int>(nAz) - 2; a >= 0; --a) {
            azRad_.push_back((360.0 - data.azimuthDeg[a]) * kDeg);
            rowOf.push_back(a);
        }
    for (double r : data.radialDeg) radRad_.push_back(r * kDeg);
    const size_t nAzX = azRad_.size();
    cellSolidAngle_.resize((nAzX - 1) * (nRad - 1));
    for (size_t a = 0; a + 1 < nAzX; ++a)
        for (size_t r = 0; r + 1 < nRad; ++r)
            cellSolidAngle_[a * (nRad - 1) + r] =
                (azRad_[a + 1] - azRad_[a]) * (std::cos(radRad_[r]) - std::cos(radRad_[r + 1]));

    for (const ZemaxBsdfBlock& src : data.blocks) {
        incidenceDeg_.push_back(src.incidenceDeg);
        fileTis_.push_back(src.fileTis);
        Block b;
        b.values.resize(nAzX * nRad);
        for (size_t a = 0; a < nAzX; ++a)
            for (size_t r = 0; r < nRad; ++r)
                b.values[a * nRad + r] = src.values[rowOf[a] * nRad + r];
        blocks_.push_back(std::move(b));
    }
    if (scaleToFileTis)
        for (size_t k = 0; k < blocks_.size(); ++k) {
            const double own = blockIntegral(blocks_[k], incidenceDeg_[k], 3);
            if (fileTis_[k] == 0.0) {
                std::fill(blocks_[k].values.begin(), blocks_[k].values.end(), 0.0);
                continue;
            }
            if (!(own > 0.0))
                throw ModelError(source_, "the block at " + std::to_string(incidenceDeg_[k]) +
                                              " deg states TIS " + std::to_string(fileTis_[k]) +
                                              " but its table scatters nothing above the "
                                              "surface: it cannot be scaled to it");
            for (double& v : blocks_[k].values) v *= fileTis_[k] / own;
        }
    for (Block& b : blocks_) buildBounds(b);

    tisTable_.resize(kTisSteps + 1);
    tbb::parallel_for(0, kTisSteps + 1, [&](int i) {
        const double theta = i * kTisStepDeg;
        const Blend w = blend(theta);
        double v = (1.0 - w.t) * blockIntegral(blocks_[w.k0], theta, 3);
        if (w.t > 0.0) v += w.t * blockIntegral(blocks_[w.k1], theta, 3);
        tisTable_[i] = v;
    });
    for (int i = 0; i <= kTisSteps; ++i)
        if (tisTable_[i] > maxTis_) maxTis_ = tisTable_[i];
    if (maxTis_ > 1.0) {
        int worst = 0;
        for (int i = 0; i <= kTisSteps; ++i)
            if (tisTable_[i] > tisTable_[worst]) worst = i;
        std::ostringstream os;
        os << "the table scatters " << maxTis_ << " of the light (more than all of it) at "
           << worst * kTisStepDeg << " deg";
        throw ModelError(source_, os.str());
    }
}

void TabulatedLobe::buildBounds(Block& b) const {
    const size_t nRad = radRad_.size(), nAzX = azRad_.size();
    b.bound.resize(cellSolidAngle_.size());
    b.cdf.resize(cellSolidAngle_.size());
    double sum = 0.0;
    for (size_t a = 0; a + 1 < nAzX; ++a)
        for (size_t r = 0; r + 1 < nRad; ++r) {
            const size_t c = a * (nRad - 1) + r;
            b.bound[c] = std::max({b.values[a * nRad + r], b.values[a * nRad + r + 1],
                                   b.values[(a + 1) * nRad + r], b.values[(a + 1) * nRad + r + 1]});
            sum += b.bound[c] * cellSolidAngle_[c];
            b.cdf[c] = sum;
        }
    b.mass = sum;
}

TabulatedLobe::Blend TabulatedLobe::blend(double thetaDeg) const {
    Blend w;
    const int n = static_cast<int>(incidenceDeg_.size());
    if (n == 1 || thetaDeg <= incidenceDeg_.front()) return w;
    if (thetaDeg >= incidenceDeg_.back()) {
        w.k0 = w.k1 = n - 1;
        return w;
    }
    const int k =
        static_cast<int>(std::upper_bound(incidenceDeg_.begin(), incidenceDeg_.end(), thetaDeg) -
                         incidenceDeg_.begin()) -
        1;
    w.k0 = k;
    w.k1 = k + 1;
    w.t = (thetaDeg - incidenceDeg_[k]) / (incidenceDeg_[k + 1] - incidenceDeg_[k]);
    return w;
}

int TabulatedLobe::cellOf(double r, double phi, double& fr, double& fp) const {
    if (!(r >= 0.0) || r > radRad_.back()) return -1;
    phi = std::fmod(phi, 2.0 * kPi);
    if (phi < 0.0) phi += 2.0 * kPi;
    const size_t nRad = radRad_.size();
    size_t j = std::upper_bound(radRad_.begin(), radRad_.end(), r) - radRad_.begin();
    j = std::clamp<size_t>(j, 1, nRad - 1) - 1;
    size_t i = std::upper_bound(azRad_.begin(), azRad_.end(), phi) - azRad_.begin();
    i = std::clamp<size_t>(i, 1, azRad_.size() - 1) - 1;
    fr = std::clamp((r - radRad_[j]) / (radRad_[j + 1] - radRad_[j]), 0.0, 1.0);
    fp = std::clamp((phi - azRad_[i]) / (azRad_[i + 1] - azRad_[i]), 0.0, 1.0);
    return static_cast<int>(i * (nRad - 1) + j);
}

double TabulatedLobe::blockValue(const Block& b, int cell, double fr, double fp) const {
    const size_t nRad = radRad_.size();
    const size_t i = cell / (nRad - 1), j = cell % (nRad - 1);
    const double* row0 = &b.values[i * nRad + j];
    const double* row1 = &b.values[(i + 1) * nRad + j];
    return (1.0 - fp) * ((1.0 - fr) * row0[0] + fr * row0[1]) +
           fp * ((1.0 - fr) * row1[0] + fr * row1[1]);
}

double TabulatedLobe::bsdf(double thetaDeg, double r, double phi) const {
    const double th = thetaDeg * kDeg;
    if (!(cosFromNormal(std::cos(th), std::sin(th), r, phi) > 0.0)) return 0.0;
    double fr = 0.0, fp = 0.0;
    const int cell = cellOf(r, phi, fr, fp);
    if (cell < 0) return 0.0;
    const Blend w = blend(thetaDeg);
    double v = (1.0 - w.t) * blockValue(blocks_[w.k0], cell, fr, fp);
    if (w.t > 0.0) v += w.t * blockValue(blocks_[w.k1], cell, fr, fp);
    return v;
}

// Integral of the block's interpolant times cos(s) over the hemisphere for specular angle
// thetaDeg: Gauss-Legendre of `order` points per cell in azimuth and radial angle (the
// interpolant is bilinear there; the measure sin r and cos(s) are smooth but for the horizon).
double TabulatedLobe::blockIntegral(const Block& b, double thetaDeg, int order) const {
    const double th = thetaDeg * kDeg, cosT = std::cos(th), sinT = std::sin(th);
    const auto& g3 = lobe::gauss<3>();
    const auto& g8 = lobe::gauss<8>();
    const double* x = order <= 3 ? g3.x.data() : g8.x.data();
    const double* w = order <= 3 ? g3.w.data() : g8.w.data();
    const int n = order <= 3 ? 3 : 8;
    const size_t nRad = radRad_.size(), nAzX = azRad_.size();
    double sum = 0.0;
    for (size_t a = 0; a + 1 < nAzX; ++a) {
        const double p0 = azRad_[a], dp = azRad_[a + 1] - p0;
        for (size_t j = 0; j + 1 < nRad; ++j) {
            const size_t cell = a * (nRad - 1) + j;
            if (!b.bound.empty() && b.bound[cell] == 0.0) continue;
            const double r0 = radRad_[j], dr = radRad_[j + 1] - r0;
            double cellSum = 0.0;
            for (int ip = 0; ip < n; ++ip) {
                const double fp = 0.5 * (x[ip] + 1.0);
                const double phi = p0 + fp * dp;
                for (int ir = 0; ir < n; ++ir) {
                    const double fr = 0.5 * (x[ir] + 1.0);
                    const double r = r0 + fr * dr;
                    const double c = cosFromNormal(cosT, sinT, r, phi);
                    if (c <= 0.0) continue;
                    cellSum += w[ip] * w[ir] * blockValue(b, static_cast<int>(cell), fr, fp) * c *
                               std::sin(r);
                }
            }
            sum += cellSum * 0.25 * dp * dr;
        }
    }
    return sum;
}

double TabulatedLobe::tis(double thetaDeg) const {
    const double x = std::clamp(thetaDeg, 0.0, 90.0) / kTisStepDeg;
    const int i = std::clamp(static_cast<int>(x), 0, kTisSteps - 1);
    const double f = x - i;
    return (1.0 - f) * tisTable_[i] + f * tisTable_[i + 1];
}

double TabulatedLobe::tisExact(double thetaDeg) const {
    const Blend w = blend(thetaDeg);
    double v = (1.0 - w.t) * blockIntegral(blocks_[w.k0], thetaDeg, 8);
    if (w.t > 0.0) v += w.t * blockIntegral(blocks_[w.k1], thetaDeg, 8);
    return v;
}

bool TabulatedLobe::sample(double thetaDeg, double u1, double u2, double& r, double& phi) const {
    const Blend w = blend(thetaDeg);
    const Block& b0 = blocks_[w.k0];
    const Block& b1 = blocks_[w.k1];
    const double m0 = (1.0 - w.t) * b0.mass, m1 = w.t * b1.mass;
    if (!(m0 + m1 > 0.0)) return false;
    const double th = thetaDeg * kDeg, cosT = std::cos(th), sinT = std::sin(th);
    const size_t nRad = radRad_.size();
    // Every uniform comes from a stream keyed by (u1, u2): the outcome is theirs alone.
    CounterRng rng(std::bit_cast<uint64_t>(u1), std::bit_cast<uint64_t>(u2));
    for (int k = 0; k < kMaxTries; ++k) {
        const Block& b = rng.uniform() * (m0 + m1) < m0 ? b0 : b1;
        const double x = rng.uniform() * b.mass;
        const size_t cell = std::min<size_t>(
            std::upper_bound(b.cdf.begin(), b.cdf.end(), x) - b.cdf.begin(), b.cdf.size() - 1);
        const size_t i = cell / (nRad - 1), j = cell % (nRad - 1);
        const double fp = rng.uniform();
        const double c0 = std::cos(radRad_[j]), c1 = std::cos(radRad_[j + 1]);
        const double cr = c0 + rng.uniform() * (c1 - c0);
        const double rr = std::acos(std::clamp(cr, -1.0, 1.0));
        const double pp = azRad_[i] + fp * (azRad_[i + 1] - azRad_[i]);
        const double fr = std::clamp((rr - radRad_[j]) / (radRad_[j + 1] - radRad_[j]), 0.0, 1.0);
        const double c = cosFromNormal(cosT, sinT, rr, pp);
        if (!(c > 0.0)) continue;
        const double target = (1.0 - w.t) * blockValue(b0, static_cast<int>(cell), fr, fp) +
                              w.t * blockValue(b1, static_cast<int>(cell), fr, fp);
        const double bound = (1.0 - w.t) * b0.bound[cell] + w.t * b1.bound[cell];
        if (rng.uniform() * bound < target * c) {
            r = rr;
            phi = pp;
            return true;
        }
    }
    return false;
}

TabulatedScatter::TabulatedScatter(std::shared_ptr<const TabulatedLobe> brdf,
                                   std::shared_ptr<const TabulatedLobe> btdf)
    : reflect_(std::move(brdf)), transmit_(std::move(btdf)) {}

std::ostream& operator<<(std::ostream& os, const TabulatedScatter& s) {
    os << "tabulated{";
    if (s.reflectLobe()) os << "brdf '" << s.reflectLobe()->source() << "'";
    if (s.reflectLobe() && s.transmitLobe()) os << ", ";
    if (s.transmitLobe()) os << "btdf '" << s.transmitLobe()->source() << "'";
    return os << "}";
}

}  // namespace veil
