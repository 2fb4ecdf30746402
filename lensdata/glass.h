#pragma once
// Optical glass: refractive index versus wavelength, and internal transmittance.
//
// Indices are relative to air at the catalog's reference conditions (20 C, 1 atm), as glass
// catalogs publish them; wavelengths are in air. This is the convention of lens design
// programs, and it makes the index of air exactly 1 in a lens prescription. The absolute
// index of air itself is available from airIndex() for systems in vacuum.
//
// Formulas (lambda in micrometres), numbered as in the AGF catalog format, coefficients in
// the order an AGF CD line gives them. Checked against the OpticStudio manual ("The Glass
// Dispersion Formulas") as transcribed by Beadie and Flynn's dispersion code; note that some
// open-source AGF readers get Sellmeier 2 wrong (B2 l^2 in the numerator, unsquared
// resonances). None of the built-in catalogs uses formula 4.
//   1  Schott       n^2 = a0 + a1 l^2 + a2 l^-2 + a3 l^-4 + a4 l^-6 + a5 l^-8
//   2  Sellmeier 1  n^2 - 1 = sum_{i=1..3} K_i l^2 / (l^2 - L_i)          (K1 L1 K2 L2 K3 L3)
//   3  Herzberger   n = A + B L + C L^2 + D l^2 + E l^4 + F l^6,  L = 1 / (l^2 - 0.028)
//   4  Sellmeier 2  n^2 - 1 = A + B1 l^2 / (l^2 - l1^2) + B2 / (l^2 - l2^2)   (A B1 l1 B2 l2)
//   5  Conrady      n = n0 + A / l + B / l^3.5
//   6  Sellmeier 3  n^2 - 1 = sum_{i=1..4} K_i l^2 / (l^2 - L_i)
//   7  Handbook of Optics 1  n^2 = A + B / (l^2 - C) - D l^2
//   8  Handbook of Optics 2  n^2 = A + B l^2 / (l^2 - C) - D l^2
//   9  Sellmeier 4  n^2 = A + B l^2 / (l^2 - C) + D l^2 / (l^2 - E)
//   10 Extended 1   n^2 = a0 + a1 l^2 + a2 l^-2 + a3 l^-4 + a4 l^-6 + a5 l^-8 + a6 l^-10 + a7 l^-12
//   11 Sellmeier 5  n^2 - 1 = sum_{i=1..5} K_i l^2 / (l^2 - L_i)
//   12 Extended 2   n^2 = a0 + a1 l^2 + a2 l^-2 + a3 l^-4 + a4 l^-6 + a5 l^-8 + a6 l^4 + a7 l^6
//   13 Extended 3   n^2 = a0 + a1 l^2 + a2 l^4 + a3 l^-2 + a4 l^-4 + a5 l^-6 + a6 l^-8
//                         + a7 l^-10 + a8 l^-12
// Model glasses (given by nd, Vd and optionally dPgF) use DispersionFormula::Model,
// documented at Glass::model().

#include <limits>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace veil {

enum class DispersionFormula {
    Schott = 1,
    Sellmeier1 = 2,
    Herzberger = 3,
    Sellmeier2 = 4,
    Conrady = 5,
    Sellmeier3 = 6,
    HandbookOfOptics1 = 7,
    HandbookOfOptics2 = 8,
    Sellmeier4 = 9,
    Extended1 = 10,
    Sellmeier5 = 11,
    Extended2 = 12,
    Extended3 = 13,
    Model = 100,  // veil's model-glass formula n = A + B l^-2 + C l^-4 + D l^2, see Glass::model()
    Table = 101,  // measured indices, interpolated: see Glass::table()
};
std::ostream& operator<<(std::ostream& os, DispersionFormula f);
// Name as written in docs and reports ("Sellmeier 1"); the AGF number maps via the enum value.
std::string_view formulaName(DispersionFormula f);
// Number of coefficients the formula reads (Table: 0, any number of (nm, n) pairs).
int formulaCoefficientCount(DispersionFormula f);
// The formula with AGF number `agfNumber` (1..13), or nullopt for any other number.
std::optional<DispersionFormula> dispersionFormulaFromAgf(int agfNumber);

// Evaluates a dispersion formula. Coefficients beyond the formula's count are ignored,
// missing ones are zero. Returns NaN if n^2 <= 0 at that wavelength.
double evaluateDispersion(DispersionFormula formula, std::span<const double> coefficients,
                          double wavelengthUm);

// Standard spectral lines (nm), in air.
inline constexpr double kLineD = 587.5618;  // helium d
inline constexpr double kLineF = 486.1327;  // hydrogen F
inline constexpr double kLineC = 656.2725;  // hydrogen C
inline constexpr double kLineG = 435.8343;  // mercury g
inline constexpr double kLineE = 546.0740;  // mercury e
inline constexpr double kLineT = 1013.98;   // mercury t

// Catalog status of a glass, the AGF NM status field.
enum class GlassStatus { Standard = 0, Preferred = 1, Obsolete = 2, Special = 3, Melt = 4 };
std::ostream& operator<<(std::ostream& os, GlassStatus s);

// One row of a catalog's internal transmittance table.
struct TransmittancePoint {
    double wavelengthNm = 0;
    double internalTransmittance = 0;  // tau_i in [0, 1] for thicknessMm of glass
    double thicknessMm = 0;
};
std::ostream& operator<<(std::ostream& os, const TransmittancePoint& p);

class Glass {
  public:
    Glass() = default;
    Glass(std::string name, std::string catalog, DispersionFormula formula,
          std::vector<double> coefficients);

    // A model glass: nd and Vd exact, nF - nC = (nd - 1) / Vd, partial dispersion P_gF on the
    // Schott normal line plus dPgF. The curve is n = A + B l^-2 + C l^-4 + D l^2 (l in um),
    // solved exactly through the d, F, C, g and t lines from four conditions:
    //   n_d = nd,   n_F - n_C = (nd - 1) / Vd,
    //   P_gF = (n_g - n_F) / (n_F - n_C) = 0.6438 - 0.001682 Vd + dPgF,
    //   P_Ct = (n_C - n_t) / (n_F - n_C) = 0.5450 + 0.004743 Vd.
    // The two normal lines (through K7 and F2) are Schott's: SCHOTT TIE-29 "Refractive index
    // and dispersion"; P. Hartmann, "Optical Glass" (SPIE Press, 2014), eq. 3.10. The P_Ct
    // condition pins the near-infrared end; over 400..1000 nm the model stays within ~2e-4
    // of the real glass (median over the Schott catalog, given the catalog dPgF; 7x better
    // than without the t line). Named "nd/Vd" or "nd/Vd/dPgF", catalog "MODEL".
    // Vd = 0 means a constant index nd at every wavelength (no dispersion).
    static Glass model(double nd, double vd, double dPgF = 0.0);
    // A glass given by its index at a few wavelengths (a CODE V private catalog's PRV table,
    // a lens file's table form). Between the points, the natural cubic spline of n over
    // x = 1 / lambda^2 through them: the Cauchy variable, in which a glass's index is nearly
    // linear, so the spline is exact at the points and bends little between them. Outside,
    // the spline's end lines (a natural spline's ends are straight), and inRange() is false.
    // Coefficients: nm0, n0, nm1, n1, ... by increasing wavelength. Needs at least two
    // points, distinct wavelengths > 0 and finite indices > 0 (std::invalid_argument).
    static Glass table(std::string name, std::vector<double> wavelengthsNm,
                       std::vector<double> indices);
    // A glass given by one of the catalog formulas and its coefficients (a lens file's own
    // glass, a CODE V private glass's LAU), catalog "PRIVATE". Needs at most the formula's
    // coefficient count and a finite real index at the d line (std::invalid_argument).
    static Glass withFormula(std::string name, DispersionFormula formula,
                             std::vector<double> coefficients);

    const std::string& name() const { return name_; }
    const std::string& catalog() const { return catalog_; }
    DispersionFormula formula() const { return formula_; }
    const std::vector<double>& coefficients() const { return coefficients_; }
    // A copy with other dispersion coefficients (same name, catalog, formula and data).
    Glass withCoefficients(std::vector<double> coefficients) const;

    // Refractive index relative to air at the given wavelength (nm, in air). Outside
    // [minWavelengthNm, maxWavelengthNm] the formula is extrapolated (see inRange()).
    double index(double wavelengthNm) const;
    // Whether the wavelength lies in the formula's validity range (true when it is unknown).
    bool inRange(double wavelengthNm) const;

    // Catalog data (NaN when unknown).
    double ndCatalog = std::numeric_limits<double>::quiet_NaN();
    double vdCatalog = std::numeric_limits<double>::quiet_NaN();
    double minWavelengthNm = 0;  // validity range of the formula; 0 = unknown
    double maxWavelengthNm = 0;
    std::vector<TransmittancePoint> transmittance;  // sorted by wavelength
    std::string comment;                            // AGF GC line

    // The rest of an AGF record, kept as read so that catalogs can be written back.
    std::string milCode;                         // NM MIL/glass code, e.g. "517642.251"
    GlassStatus status = GlassStatus::Standard;  // NM status
    bool excludeSubstitution = false;            // NM exclude-from-substitution flag
    int meltFrequency = 0;                       // NM melt frequency; 0 = not given
    // ED line: TCE(-30..70 C) 1e-6/K, TCE(100..300 C), density g/cm^3, dPgF, ignore-TCE flag.
    std::vector<double> extraData;
    // TD line: D0 D1 D2 E0 E1 lambda_tk(um) Tref(C), the Schott dn/dT model. Not applied yet.
    std::vector<double> thermalData;
    // Deviation of P_gF from the Schott normal line, from ED (NaN when unknown).
    double dPgF() const;

    // Internal transmittance of a path of thicknessMm (>= 0) at wavelengthNm, interpolated
    // from the catalog table: all rows are first brought to the thickness of the first row by
    // Beer-Lambert, tau_ref is interpolated linearly in wavelength between rows (clamped to
    // the end rows outside the table), then tau = tau_ref^(thicknessMm / thickness_ref).
    // nullopt when the catalog has no table.
    std::optional<double> internalTransmittance(double wavelengthNm, double thicknessMm) const;
    // Absorption coefficient alpha (1/mm), tau = exp(-alpha d), from the same interpolation.
    // +infinity where the table says tau = 0. nullopt when unknown.
    std::optional<double> absorptionPerMm(double wavelengthNm) const;

    // Abbe number from the formula: (n_d - 1) / (n_F - n_C).
    double abbeNumber() const;

  private:
    std::string name_;
    std::string catalog_;
    DispersionFormula formula_ = DispersionFormula::Schott;
    std::vector<double> coefficients_;
};
// "Glass{SCHOTT N-BK7, Sellmeier 1, nd=1.5168, vd=64.17}"
std::ostream& operator<<(std::ostream& os, const Glass& g);

// Air for airIndex(). The defaults are Ciddor's standard air.
struct AirConditions {
    double temperatureC = 15.0;
    double pressurePa = 101325.0;
    double relativeHumidity = 0.0;  // 0..1
    double co2Ppm = 450.0;

    // Dry air at 20 C and 101325 Pa, the reference air of the Schott and CDGM catalogs.
    static AirConditions catalogReference() { return {20.0, 101325.0, 0.0, 450.0}; }
};
std::ostream& operator<<(std::ostream& os, const AirConditions& a);

// Absolute refractive index of standard air (15 C, 101325 Pa, dry, 450 ppm CO2) from
// Ciddor (1996), wavelength in vacuum (nm). Used for systems in vacuum.
double airIndex(double vacuumWavelengthNm);
// Ciddor, P. E., "Refractive index of air: new equations for the visible and near infrared",
// Appl. Opt. 35, 1566-1573 (1996), for any air: the full equation with compressibility,
// water vapour (saturation pressure from IAPWS over water, from the ice formula below 0 C,
// as in the NIST Engineering Metrology Toolbox) and CO2. Valid 300..1700 nm, -40..100 C,
// 10..140 kPa, 0..100 % relative humidity; reproduces the NIST table to 1e-9.
double airIndex(double vacuumWavelengthNm, const AirConditions& air);

}  // namespace veil
