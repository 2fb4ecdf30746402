#include "lensdata/glass.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace veil {

// Dispersion Formulas

std::string_view formulaName(DispersionFormula f) {
    switch (f) {
        case DispersionFormula::Schott:
            return "Schott";
        case DispersionFormula::Sellmeier1:
            return "Sellmeier 1";
        case DispersionFormula::Herzberger:
            return "Herzberger";
        case DispersionFormula::Sellmeier2:
            return "Sellmeier 2";
        case DispersionFormula::Conrady:
            return "Conrady";
        case DispersionFormula::Sellmeier3:
            return "Sellmeier 3";
        case DispersionFormula::HandbookOfOptics1:
            return "Handbook of Optics 1";
        case DispersionFormula::HandbookOfOptics2:
            return "Handbook of Optics 2";
        case DispersionFormula::Sellmeier4:
            return "Sellmeier 4";
        case DispersionFormula::Extended1:
            return "Extended 1";
        case DispersionFormula::Sellmeier5:
            return "Sellmeier 5";
        case DispersionFormula::Extended2:
            return "Extended 2";
        case DispersionFormula::Extended3:
            return "Extended 3";
        case DispersionFormula::Model:
            return "Model";
        case DispersionFormula::Table:
            return "Table";
    }
    return "unknown formula";
}

std::ostream& operator<<(std::ostream& os, DispersionFormula f) { return os << formulaName(f); }

int formulaCoefficientCount(DispersionFormula f) {
    switch (f) {
        case DispersionFormula::Schott:
            return 6;
        case DispersionFormula::Sellmeier1:
            return 6;
        case DispersionFormula::Herzberger:
            return 6;
        case DispersionFormula::Sellmeier2:
            return 5;
        case DispersionFormula::Conrady:
            return 3;
        case DispersionFormula::Sellmeier3:
            return 8;
        case DispersionFormula::HandbookOfOptics1:
            return 4;
        case DispersionFormula::HandbookOfOptics2:
            return 4;
        case DispersionFormula::Sellmeier4:
            return 5;
        case DispersionFormula::Extended1:
            return 8;
        case DispersionFormula::Sellmeier5:
            return 10;
        case DispersionFormula::Extended2:
            return 8;
        case DispersionFormula::Extended3:
            return 9;
        case DispersionFormula::Model:
            return 4;
        case DispersionFormula::Table:
            return 0;
    }
    return 0;
}

std::optional<DispersionFormula> dispersionFormulaFromAgf(int agfNumber) {
    if (agfNumber < 1 || agfNumber > 13) return std::nullopt;
    return static_cast<DispersionFormula>(agfNumber);
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// n from n^2, NaN where n^2 <= 0 (the formula is meaningless there).
double rootOrNaN(double n2) { return n2 > 0.0 ? std::sqrt(n2) : kNaN; }

// sum_i K_i l2 / (l2 - L_i) over `terms` (K, L) pairs starting at c[first].
double sellmeierSum(const std::array<double, 12>& c, int first, int terms, double l2) {
    double s = 0.0;
    for (int i = 0; i < terms; ++i) s += c[first + 2 * i] * l2 / (l2 - c[first + 2 * i + 1]);
    return s;
}

// The natural cubic spline of n over x = 1 / lambda^2 through a table's (nm, n) pairs (by
// increasing wavelength, so by decreasing x), at wavelength `um`; straight beyond its ends.
double tableIndex(std::span<const double> c, double um) {
    const size_t n = c.size() / 2;
    if (n == 0) return kNaN;
    if (n == 1) return c[1];
    // Points by increasing x.
    std::vector<double> x(n), y(n);
    for (size_t i = 0; i < n; ++i) {
        const double l = c[2 * (n - 1 - i)] * 1e-3;
        x[i] = 1.0 / (l * l);
        y[i] = c[2 * (n - 1 - i) + 1];
    }
    // Second derivatives m (m[0] = m[n-1] = 0, natural): the tridiagonal system
    //   h[i-1]/6 m[i-1] + (h[i-1] + h[i])/3 m[i] + h[i]/6 m[i+1] = slope[i] - slope[i-1]
    // by Thomas' algorithm (diagonally dominant: no pivoting needed).
    std::vector<double> m(n, 0.0), diag(n, 0.0), rhs(n, 0.0);
    for (size_t i = 1; i + 1 < n; ++i) {
        const double h0 = x[i] - x[i - 1], h1 = x[i + 1] - x[i];
        diag[i] = (h0 + h1) / 3.0;
        rhs[i] = (y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0;
        if (i > 1) {
            const double w = (h0 / 6.0) / diag[i - 1];
            diag[i] -= w * h0 / 6.0;  // the row above's super-diagonal, h[i-1] / 6
            rhs[i] -= w * rhs[i - 1];
        }
    }
    for (size_t i = n - 2; i >= 1; --i) {
        m[i] = (rhs[i] - (x[i + 1] - x[i]) / 6.0 * m[i + 1]) / diag[i];
        if (i == 1) break;
    }
    const double xv = 1.0 / (um * um);
    // The segment holding xv (the end ones beyond the table).
    size_t k = 0;
    while (k + 2 < n && xv > x[k + 1]) ++k;
    const double h = x[k + 1] - x[k];
    if (xv < x[0] || xv > x[n - 1]) {
        // Straight: the spline's slope at the end.
        const bool low = xv < x[0];
        const size_t e = low ? 0 : n - 1;
        const double slope =
            low ? (y[1] - y[0]) / h - h * (2.0 * m[0] + m[1]) / 6.0
                : (y[n - 1] - y[n - 2]) / h + h * (m[n - 2] + 2.0 * m[n - 1]) / 6.0;
        return y[e] + slope * (xv - x[e]);
    }
    const double a = (x[k + 1] - xv) / h, b = (xv - x[k]) / h;
    return a * y[k] + b * y[k + 1] +
           ((a * a * a - a) * m[k] + (b * b * b - b) * m[k + 1]) * h * h / 6.0;
}

}  // namespace

double evaluateDispersion(DispersionFormula formula, std::span<const double> coefficients,
                          double wavelengthUm) {
    if (formula == DispersionFormula::Table) return tableIndex(coefficients, wavelengthUm);
    // Copy into a zero-padded array: missing coefficients are zero, extra ones ignored.
    std::array<double, 12> c{};
    const size_t count = std::min<size_t>(coefficients.size(), formulaCoefficientCount(formula));
    std::copy_n(coefficients.begin(), count, c.begin());

    const double l = wavelengthUm;
    const double l2 = l * l;
    const double il2 = 1.0 / l2;
    switch (formula) {
        case DispersionFormula::Schott:
            return rootOrNaN(c[0] + c[1] * l2 +
                             il2 * (c[2] + il2 * (c[3] + il2 * (c[4] + il2 * c[5]))));
        case DispersionFormula::Sellmeier1:
            return rootOrNaN(1.0 + sellmeierSum(c, 0, 3, l2));
        case DispersionFormula::Herzberger: {
            const double L = 1.0 / (l2 - 0.028);
            return c[0] + L * (c[1] + L * c[2]) + l2 * (c[3] + l2 * (c[4] + l2 * c[5]));
        }
        case DispersionFormula::Sellmeier2:
            return rootOrNaN(1.0 + c[0] + c[1] * l2 / (l2 - c[2] * c[2]) +
                             c[3] / (l2 - c[4] * c[4]));
        case DispersionFormula::Conrady:
            return c[0] + c[1] / l + c[2] / std::pow(l, 3.5);
        case DispersionFormula::Sellmeier3:
            return rootOrNaN(1.0 + sellmeierSum(c, 0, 4, l2));
        case DispersionFormula::HandbookOfOptics1:
            return rootOrNaN(c[0] + c[1] / (l2 - c[2]) - c[3] * l2);
        case DispersionFormula::HandbookOfOptics2:
            return rootOrNaN(c[0] + c[1] * l2 / (l2 - c[2]) - c[3] * l2);
        case DispersionFormula::Sellmeier4:
            return rootOrNaN(c[0] + sellmeierSum(c, 1, 2, l2));
        case DispersionFormula::Extended1:
            return rootOrNaN(
                c[0] + c[1] * l2 +
                il2 * (c[2] +
                       il2 * (c[3] + il2 * (c[4] + il2 * (c[5] + il2 * (c[6] + il2 * c[7]))))));
        case DispersionFormula::Sellmeier5:
            return rootOrNaN(1.0 + sellmeierSum(c, 0, 5, l2));
        case DispersionFormula::Extended2:
            return rootOrNaN(c[0] + l2 * (c[1] + l2 * (c[6] + l2 * c[7])) +
                             il2 * (c[2] + il2 * (c[3] + il2 * (c[4] + il2 * c[5]))));
        case DispersionFormula::Extended3:
            return rootOrNaN(
                c[0] + l2 * (c[1] + l2 * c[2]) +
                il2 * (c[3] +
                       il2 * (c[4] + il2 * (c[5] + il2 * (c[6] + il2 * (c[7] + il2 * c[8]))))));
        case DispersionFormula::Model:
            return c[0] + il2 * (c[1] + il2 * c[2]) + c[3] * l2;
        case DispersionFormula::Table:
            break;  // above
    }
    return kNaN;
}

// Small Printable Types

std::ostream& operator<<(std::ostream& os, GlassStatus s) {
    switch (s) {
        case GlassStatus::Standard:
            return os << "standard";
        case GlassStatus::Preferred:
            return os << "preferred";
        case GlassStatus::Obsolete:
            return os << "obsolete";
        case GlassStatus::Special:
            return os << "special";
        case GlassStatus::Melt:
            return os << "melt";
    }
    return os << "status " << static_cast<int>(s);
}

std::ostream& operator<<(std::ostream& os, const TransmittancePoint& p) {
    return os << "TransmittancePoint{" << p.wavelengthNm << " nm, tau=" << p.internalTransmittance
              << " for " << p.thicknessMm << " mm}";
}

// Glass Methods

Glass::Glass(std::string name, std::string catalog, DispersionFormula formula,
             std::vector<double> coefficients)
    : name_(std::move(name)),
      catalog_(std::move(catalog)),
      formula_(formula),
      coefficients_(std::move(coefficients)) {}

namespace {

// Shortest decimal that reads back as `v` ("1.5168", "64.17").
std::string shortest(double v) {
    char buf[32];
    auto r = std::to_chars(buf, buf + sizeof(buf), v);
    return std::string(buf, r.ptr);
}

// Basis of the model curve, n = A + B l^-2 + C l^-4 + D l^2, at l um.
std::array<double, 4> modelBasis(double wavelengthNm) {
    const double l2 = (wavelengthNm * 1e-3) * (wavelengthNm * 1e-3);
    return {1.0, 1.0 / l2, 1.0 / (l2 * l2), l2};
}

std::array<double, 4> minus(const std::array<double, 4>& a, const std::array<double, 4>& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]};
}

// Solves the 4x4 system m x = rhs by Gaussian elimination with partial pivoting.
std::array<double, 4> solve4(std::array<std::array<double, 4>, 4> m, std::array<double, 4> rhs) {
    for (int col = 0; col < 4; ++col) {
        int pivot = col;
        for (int r = col + 1; r < 4; ++r)
            if (std::abs(m[r][col]) > std::abs(m[pivot][col])) pivot = r;
        std::swap(m[col], m[pivot]);
        std::swap(rhs[col], rhs[pivot]);
        for (int r = col + 1; r < 4; ++r) {
            const double f = m[r][col] / m[col][col];
            for (int k = col; k < 4; ++k) m[r][k] -= f * m[col][k];
            rhs[r] -= f * rhs[col];
        }
    }
    std::array<double, 4> x{};
    for (int r = 3; r >= 0; --r) {
        double s = rhs[r];
        for (int k = r + 1; k < 4; ++k) s -= m[r][k] * x[k];
        x[r] = s / m[r][r];
    }
    return x;
}

}  // namespace

Glass Glass::model(double nd, double vd, double dPgF) {
    if (!(std::isfinite(nd) && nd > 0.0) || !(std::isfinite(vd) && vd >= 0.0) ||
        !std::isfinite(dPgF)) {
        std::ostringstream msg;
        msg << "Glass::model needs finite nd > 0 and Vd >= 0, got nd=" << nd << " vd=" << vd
            << " dPgF=" << dPgF;
        throw std::invalid_argument(msg.str());
    }
    if (vd == 0.0) {
        // Vd = 0 stands for a constant, dispersion-free index (as in lens design programs).
        Glass glass(shortest(nd), "MODEL", DispersionFormula::Model, {nd, 0.0, 0.0, 0.0});
        glass.ndCatalog = nd;
        glass.vdCatalog = 0.0;
        return glass;
    }
    // Schott normal lines (see glass.h).
    const double dispersion = (nd - 1.0) / vd;  // n_F - n_C
    const double pgF = 0.6438 - 0.001682 * vd + dPgF;
    const double pCt = 0.5450 + 0.004743 * vd;

    const auto d = modelBasis(kLineD), f = modelBasis(kLineF), c = modelBasis(kLineC);
    const auto g = modelBasis(kLineG), t = modelBasis(kLineT);
    const std::array<double, 4> x = solve4({d, minus(f, c), minus(g, f), minus(c, t)},
                                           {nd, dispersion, pgF * dispersion, pCt * dispersion});

    // Appended piece by piece: "a" + "/" + "b" trips GCC 12's -Wrestrict false positive.
    std::string name = shortest(nd);
    name += '/';
    name += shortest(vd);
    if (dPgF != 0.0) {
        name += '/';
        name += shortest(dPgF);
    }
    Glass glass(std::move(name), "MODEL", DispersionFormula::Model, {x[0], x[1], x[2], x[3]});
    glass.ndCatalog = nd;
    glass.vdCatalog = vd;
    glass.extraData = {0.0, 0.0, 0.0, dPgF, 0.0};
    return glass;
}

Glass Glass::table(std::string name, std::vector<double> wavelengthsNm,
                   std::vector<double> indices) {
    if (wavelengthsNm.size() != indices.size())
        throw std::invalid_argument("a glass table needs one index per wavelength (" +
                                    std::to_string(wavelengthsNm.size()) + " wavelengths, " +
                                    std::to_string(indices.size()) + " indices)");
    if (wavelengthsNm.size() < 2)
        throw std::invalid_argument("a glass table needs at least two wavelengths");
    std::vector<std::pair<double, double>> points;
    for (size_t i = 0; i < indices.size(); ++i) {
        if (!(std::isfinite(wavelengthsNm[i]) && wavelengthsNm[i] > 0.0))
            throw std::invalid_argument("a glass table's wavelength " + shortest(wavelengthsNm[i]) +
                                        " nm is not > 0");
        if (!(std::isfinite(indices[i]) && indices[i] > 0.0))
            throw std::invalid_argument("a glass table's index " + shortest(indices[i]) + " at " +
                                        shortest(wavelengthsNm[i]) + " nm is not > 0");
        points.emplace_back(wavelengthsNm[i], indices[i]);
    }
    std::sort(points.begin(), points.end());
    std::vector<double> c;
    for (size_t i = 0; i < points.size(); ++i) {
        if (i > 0 && points[i].first == points[i - 1].first)
            throw std::invalid_argument("a glass table gives " + shortest(points[i].first) +
                                        " nm twice");
        c.push_back(points[i].first);
        c.push_back(points[i].second);
    }
    Glass glass(std::move(name), "TABLE", DispersionFormula::Table, std::move(c));
    glass.minWavelengthNm = points.front().first;
    glass.maxWavelengthNm = points.back().first;
    glass.ndCatalog = glass.index(kLineD);
    glass.vdCatalog = glass.abbeNumber();
    return glass;
}

Glass Glass::withFormula(std::string name, DispersionFormula formula,
                         std::vector<double> coefficients) {
    const int most = formulaCoefficientCount(formula);
    if (formula == DispersionFormula::Table || formula == DispersionFormula::Model ||
        coefficients.size() > static_cast<size_t>(most))
        throw std::invalid_argument("the " + std::string(formulaName(formula)) + " formula takes " +
                                    std::to_string(most) + " coefficients (got " +
                                    std::to_string(coefficients.size()) + ")");
    Glass glass(std::move(name), "PRIVATE", formula, std::move(coefficients));
    glass.ndCatalog = glass.index(kLineD);
    if (!(glass.ndCatalog > 0.0) || !std::isfinite(glass.ndCatalog))
        throw std::invalid_argument("the formula gives no real index at the d line");
    glass.vdCatalog = glass.abbeNumber();
    return glass;
}

Glass Glass::withCoefficients(std::vector<double> coefficients) const {
    Glass copy = *this;
    copy.coefficients_ = std::move(coefficients);
    return copy;
}

double Glass::index(double wavelengthNm) const {
    return evaluateDispersion(formula_, coefficients_, wavelengthNm * 1e-3);
}

bool Glass::inRange(double wavelengthNm) const {
    if (minWavelengthNm > 0.0 && wavelengthNm < minWavelengthNm) return false;
    if (maxWavelengthNm > 0.0 && wavelengthNm > maxWavelengthNm) return false;
    return true;
}

double Glass::dPgF() const { return extraData.size() >= 4 ? extraData[3] : kNaN; }

double Glass::abbeNumber() const { return (index(kLineD) - 1.0) / (index(kLineF) - index(kLineC)); }

namespace {

// tau of row `p` brought to `thicknessMm` by Beer-Lambert.
double transmittanceAt(const TransmittancePoint& p, double thicknessMm) {
    const double tau = std::clamp(p.internalTransmittance, 0.0, 1.0);
    if (p.thicknessMm <= 0.0 || p.thicknessMm == thicknessMm) return tau;
    return std::pow(tau, thicknessMm / p.thicknessMm);
}

// tau at the first row's thickness, interpolated linearly in wavelength and clamped at the
// table ends (see Glass::internalTransmittance).
double referenceTransmittance(const std::vector<TransmittancePoint>& table, double wavelengthNm) {
    const double ref = table.front().thicknessMm;
    if (wavelengthNm <= table.front().wavelengthNm) return transmittanceAt(table.front(), ref);
    if (wavelengthNm >= table.back().wavelengthNm) return transmittanceAt(table.back(), ref);
    auto hi =
        std::upper_bound(table.begin(), table.end(), wavelengthNm,
                         [](double w, const TransmittancePoint& p) { return w < p.wavelengthNm; });
    auto lo = hi - 1;
    const double t0 = transmittanceAt(*lo, ref), t1 = transmittanceAt(*hi, ref);
    const double span = hi->wavelengthNm - lo->wavelengthNm;
    if (span <= 0.0) return t1;
    const double u = (wavelengthNm - lo->wavelengthNm) / span;
    return t0 + u * (t1 - t0);
}

}  // namespace

std::optional<double> Glass::internalTransmittance(double wavelengthNm, double thicknessMm) const {
    if (!(thicknessMm >= 0.0)) {
        throw std::invalid_argument("Glass::internalTransmittance needs thicknessMm >= 0, got " +
                                    shortest(thicknessMm) + " (" + name_ + ")");
    }
    if (transmittance.empty()) return std::nullopt;
    const double ref = transmittance.front().thicknessMm;
    const double tauRef = referenceTransmittance(transmittance, wavelengthNm);
    if (ref <= 0.0) return tauRef;
    return std::pow(tauRef, thicknessMm / ref);
}

std::optional<double> Glass::absorptionPerMm(double wavelengthNm) const {
    if (transmittance.empty() || !(transmittance.front().thicknessMm > 0.0)) return std::nullopt;
    const double tauRef = referenceTransmittance(transmittance, wavelengthNm);
    return -std::log(tauRef) / transmittance.front().thicknessMm;
}

std::ostream& operator<<(std::ostream& os, const Glass& g) {
    os << "Glass{";
    if (!g.catalog().empty()) os << g.catalog() << ' ';
    os << (g.name().empty() ? std::string("<unnamed>") : g.name()) << ", " << g.formula();
    if (!std::isnan(g.ndCatalog)) os << ", nd=" << g.ndCatalog;
    if (!std::isnan(g.vdCatalog)) os << ", vd=" << g.vdCatalog;
    if (g.status != GlassStatus::Standard) os << ", " << g.status;
    return os << '}';
}

// Air

std::ostream& operator<<(std::ostream& os, const AirConditions& a) {
    return os << "AirConditions{" << a.temperatureC << " C, " << a.pressurePa << " Pa, RH "
              << a.relativeHumidity * 100.0 << " %, CO2 " << a.co2Ppm << " ppm}";
}

namespace {

// Saturation vapour pressure (Pa) at T (K): IAPWS-IF97 over water at or above 0 C, the
// IAPWS sublimation formula over ice below (NIST Engineering Metrology Toolbox, A-I).
double saturationVapourPressurePa(double kelvin) {
    if (kelvin >= 273.15) {
        constexpr double k1 = 1.16705214528e3, k2 = -7.24213167032e5, k3 = -1.70738469401e1;
        constexpr double k4 = 1.20208247025e4, k5 = -3.23255503223e6, k6 = 1.49151086135e1;
        constexpr double k7 = -4.82326573616e3, k8 = 4.05113405421e5, k9 = -2.38555575678e-1;
        constexpr double k10 = 6.50175348448e2;
        const double omega = kelvin + k9 / (kelvin - k10);
        const double a = omega * omega + k1 * omega + k2;
        const double b = k3 * omega * omega + k4 * omega + k5;
        const double c = k6 * omega * omega + k7 * omega + k8;
        const double x = -b + std::sqrt(b * b - 4.0 * a * c);
        return 1e6 * std::pow(2.0 * c / x, 4.0);
    }
    const double theta = kelvin / 273.16;
    const double y =
        -13.928169 * (1.0 - std::pow(theta, -1.5)) + 34.7078238 * (1.0 - std::pow(theta, -1.25));
    return 611.657 * std::exp(y);
}

// Compressibility of moist air (CIPM-81/91, as used by Ciddor), p in Pa, T in K, xw the
// molar fraction of water vapour.
double compressibility(double pressurePa, double kelvin, double xw) {
    const double t = kelvin - 273.15;
    const double pt = pressurePa / kelvin;
    return 1.0 -
           pt * (1.58123e-6 - 2.9331e-8 * t + 1.1043e-10 * t * t + (5.707e-6 - 2.051e-8 * t) * xw +
                 (1.9898e-4 - 2.376e-6 * t) * xw * xw) +
           pt * pt * (1.83e-11 - 0.765e-8 * xw * xw);
}

}  // namespace

double airIndex(double vacuumWavelengthNm, const AirConditions& air) {
    constexpr double kR = 8.314510;   // gas constant, J/(mol K)
    constexpr double kMw = 0.018015;  // molar mass of water, kg/mol
    // Wavenumber squared, um^-2.
    const double sigma2 = std::pow(1000.0 / vacuumWavelengthNm, 2.0);
    const double kelvin = air.temperatureC + 273.15;

    // Refractivity of standard air (15 C, 101325 Pa, dry, 450 ppm CO2) and its CO2 correction.
    const double ras = 1e-8 * (5792105.0 / (238.0185 - sigma2) + 167917.0 / (57.362 - sigma2));
    const double raxs = ras * (1.0 + 0.534e-6 * (air.co2Ppm - 450.0));
    // Refractivity of standard water vapour (20 C, 1333 Pa).
    const double rws =
        1.022e-8 * (295.235 + sigma2 * (2.6422 + sigma2 * (-0.032380 + sigma2 * 0.004028)));
    const double ma = 1e-3 * (28.9635 + 12.011e-6 * (air.co2Ppm - 400.0));  // kg/mol, dry air

    // Molar fraction of water vapour (enhancement factor f times the saturation pressure).
    const double f =
        1.00062 + 3.14e-8 * air.pressurePa + 5.6e-7 * air.temperatureC * air.temperatureC;
    const double xw =
        f * air.relativeHumidity * saturationVapourPressurePa(kelvin) / air.pressurePa;

    const double rhoAxs = 101325.0 * ma / (compressibility(101325.0, 288.15, 0.0) * kR * 288.15);
    const double rhoWs = 1333.0 * kMw / (compressibility(1333.0, 293.15, 1.0) * kR * 293.15);
    const double z = compressibility(air.pressurePa, kelvin, xw);
    const double rhoA = air.pressurePa * ma * (1.0 - xw) / (z * kR * kelvin);
    const double rhoW = air.pressurePa * kMw * xw / (z * kR * kelvin);
    return 1.0 + (rhoA / rhoAxs) * raxs + (rhoW / rhoWs) * rws;
}

double airIndex(double vacuumWavelengthNm) { return airIndex(vacuumWavelengthNm, {}); }

}  // namespace veil
