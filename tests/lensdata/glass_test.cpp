// Tests for lensdata/glass.h: every dispersion formula against hand-computed values,
// published data and algebraic identities between formulas; the model glass; internal
// transmittance against Beer-Lambert by hand; the index of air against the NIST table.

#include "lensdata/glass.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace veil {
namespace {

using F = DispersionFormula;

double eval(F f, const std::vector<double>& c, double wavelengthUm) {
    return evaluateDispersion(f, c, wavelengthUm);
}

template <typename T>
std::string printed(const T& v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

// Schott's published N-BK7 Sellmeier coefficients (Schott data sheet).
const std::vector<double> kNbk7 = {1.03961212,   0.00600069867, 0.231792344,
                                   0.0200179144, 1.01046945,    103.560653};

// Dispersion Formulas

TEST(DispersionFormula, NamesCountsAndAgfNumbers) {
    EXPECT_EQ(formulaName(F::Sellmeier1), "Sellmeier 1");
    EXPECT_EQ(formulaName(F::HandbookOfOptics2), "Handbook of Optics 2");
    EXPECT_EQ(printed(F::Extended3), "Extended 3");
    EXPECT_EQ(formulaCoefficientCount(F::Schott), 6);
    EXPECT_EQ(formulaCoefficientCount(F::Sellmeier2), 5);
    EXPECT_EQ(formulaCoefficientCount(F::Conrady), 3);
    EXPECT_EQ(formulaCoefficientCount(F::Sellmeier5), 10);
    EXPECT_EQ(formulaCoefficientCount(F::Extended3), 9);
    EXPECT_EQ(dispersionFormulaFromAgf(2), F::Sellmeier1);
    EXPECT_EQ(dispersionFormulaFromAgf(13), F::Extended3);
    EXPECT_FALSE(dispersionFormulaFromAgf(0));
    EXPECT_FALSE(dispersionFormulaFromAgf(14));
    EXPECT_FALSE(dispersionFormulaFromAgf(100));  // the model formula is not an AGF number
}

// Each power-series formula puts its coefficients on fixed powers of lambda^2 (glass.h).
// Setting a0 = 1 and one coefficient to 0.1 / l2^p at l = 2 um must give n^2 = 1.1: this
// pins every coefficient slot of Schott, Extended 1, 2 and 3 to its power.
TEST(DispersionFormula, PowerSeriesCoefficientsSitOnTheirPowers) {
    struct Series {
        F formula;
        std::vector<int> powersOfL2;  // per coefficient, the power of lambda^2 it multiplies
    };
    const std::vector<Series> series = {
        {F::Schott, {0, 1, -1, -2, -3, -4}},
        {F::Extended1, {0, 1, -1, -2, -3, -4, -5, -6}},
        {F::Extended2, {0, 1, -1, -2, -3, -4, 2, 3}},
        {F::Extended3, {0, 1, 2, -1, -2, -3, -4, -5, -6}},
    };
    const double l = 2.0, l2 = 4.0;
    for (const Series& s : series) {
        for (size_t k = 1; k < s.powersOfL2.size(); ++k) {
            std::vector<double> c(s.powersOfL2.size(), 0.0);
            c[0] = 1.0;
            c[k] = 0.1 / std::pow(l2, s.powersOfL2[k]);
            const double n = eval(s.formula, c, l);
            EXPECT_NEAR(n * n, 1.1, 1e-13) << s.formula << " coefficient " << k;
        }
    }
}

TEST(DispersionFormula, SchottByHand) {
    const std::vector<double> c = {2.0, -0.01, 0.01, 0.001, 1e-4, 1e-5};
    // l = 1: every power is 1.
    EXPECT_NEAR(eval(F::Schott, c, 1.0), std::sqrt(2.0 - 0.01 + 0.01 + 0.001 + 1e-4 + 1e-5), 1e-15);
    // l = 0.5: l^2 = 0.25, l^-2 = 4, l^-4 = 16, l^-6 = 64, l^-8 = 256.
    EXPECT_NEAR(eval(F::Schott, c, 0.5), std::sqrt(2.0 - 0.0025 + 0.04 + 0.016 + 0.0064 + 0.00256),
                1e-15);
}

// BK7 in the Schott formula, coefficients of the pre-1992 Schott catalog; published
// indices nd = 1.51680, nF = 1.52238, nC = 1.51432.
TEST(DispersionFormula, SchottReproducesPublishedBk7) {
    const std::vector<double> bk7 = {2.2718929,    -1.0108077e-2, 1.0592509e-2,
                                     2.0816965e-4, -7.6472538e-6, 4.9240991e-7};
    EXPECT_NEAR(eval(F::Schott, bk7, kLineD * 1e-3), 1.51680, 1e-5);
    EXPECT_NEAR(eval(F::Schott, bk7, kLineF * 1e-3), 1.52238, 1e-5);
    EXPECT_NEAR(eval(F::Schott, bk7, kLineC * 1e-3), 1.51432, 1e-5);
}

// Schott N-BK7 data sheet indices (5 decimals) from the Sellmeier 1 coefficients.
TEST(DispersionFormula, Sellmeier1ReproducesTheNbk7DataSheet) {
    struct Line {
        double nm, n;
    };
    const Line lines[] = {{365.01, 1.53627},   {404.66, 1.53024},   {435.8343, 1.52668},
                          {486.1327, 1.52238}, {546.074, 1.51872},  {587.5618, 1.51680},
                          {632.8, 1.51509},    {656.2725, 1.51432}, {706.5188, 1.51289},
                          {852.11, 1.50980},   {1013.98, 1.50731},  {1060.0, 1.50669},
                          {1529.6, 1.50091},   {1970.1, 1.49495},   {2325.4, 1.48921}};
    for (const Line& line : lines)
        EXPECT_NEAR(eval(F::Sellmeier1, kNbk7, line.nm * 1e-3), line.n, 1e-5) << line.nm << " nm";
}

TEST(DispersionFormula, SellmeierFamilyIdentities) {
    // Sellmeier 3 and 5 with their extra terms zero are Sellmeier 1.
    std::vector<double> s3 = kNbk7, s5 = kNbk7;
    s3.insert(s3.end(), {0.0, 0.5});
    s5.insert(s5.end(), {0.0, 0.5, 0.0, 7.0});
    // Sellmeier 4 with A = 1 is a two-term Sellmeier 1.
    const std::vector<double> s4 = {1.0, kNbk7[0], kNbk7[1], kNbk7[2], kNbk7[3]};
    const std::vector<double> s1TwoTerms = {kNbk7[0], kNbk7[1], kNbk7[2], kNbk7[3]};
    // Sellmeier 2 with A = 0 and B2 = 0 is a one-term Sellmeier 1 with L1 = lambda1^2.
    const std::vector<double> s2 = {0.0, 1.2, 0.1, 0.0, 3.0};
    const std::vector<double> s1OneTerm = {1.2, 0.01};
    for (double l : {0.4, 0.5875618, 0.8, 1.5, 2.2}) {
        const double s1 = eval(F::Sellmeier1, kNbk7, l);
        EXPECT_NEAR(eval(F::Sellmeier3, s3, l), s1, 1e-14) << l;
        EXPECT_NEAR(eval(F::Sellmeier5, s5, l), s1, 1e-14) << l;
        EXPECT_NEAR(eval(F::Sellmeier4, s4, l), eval(F::Sellmeier1, s1TwoTerms, l), 1e-14) << l;
        EXPECT_NEAR(eval(F::Sellmeier2, s2, l), eval(F::Sellmeier1, s1OneTerm, l), 1e-14) << l;
    }
    // The fourth and fifth terms do count when they are not zero: K4 = 0.1 at L4 = 0 adds
    // 0.1 to n^2 at any wavelength.
    s3[6] = 0.1;
    s3[7] = 0.0;
    const double n1 = eval(F::Sellmeier1, kNbk7, 0.6), n3 = eval(F::Sellmeier3, s3, 0.6);
    EXPECT_NEAR(n3 * n3 - n1 * n1, 0.1, 1e-14);
    s5[8] = 0.2;
    s5[9] = 0.0;
    const double n5 = eval(F::Sellmeier5, s5, 0.6);
    EXPECT_NEAR(n5 * n5 - n1 * n1, 0.2, 1e-14);
}

// Sellmeier 2: n^2 - 1 = A + B1 l^2 / (l^2 - l1^2) + B2 / (l^2 - l2^2). The B2 term has no
// l^2 in its numerator and the resonances are squared. A = 0.5, B1 = 1, l1 = 0.1, B2 = 0.01,
// l2 = 1 at l = 0.5: n^2 = 1 + 0.5 + 0.25 / 0.24 + 0.01 / -0.75.
TEST(DispersionFormula, Sellmeier2ByHand) {
    EXPECT_NEAR(eval(F::Sellmeier2, {0.5, 1.0, 0.1, 0.01, 1.0}, 0.5),
                std::sqrt(1.5 + 0.25 / 0.24 - 0.01 / 0.75), 1e-15);
}

// Sellmeier 4: n^2 = A + B l^2 / (l^2 - C) + D l^2 / (l^2 - E); at l = 1:
// 1.5 + 0.5 / 0.99 + 0.2 / (1 - 100).
TEST(DispersionFormula, Sellmeier4ByHand) {
    EXPECT_NEAR(eval(F::Sellmeier4, {1.5, 0.5, 0.01, 0.2, 100.0}, 1.0),
                std::sqrt(1.5 + 0.5 / 0.99 - 0.2 / 99.0), 1e-15);
}

// Herzberger at l^2 = 1.028, where L = 1 / (l^2 - 0.028) = 1:
// n = A + B + C + 1.028 D + 1.028^2 E + 1.028^3 F
//   = 1.5 + 0.004 + 0.0002 - 0.001028 + 0.0001056784 - 0.00001086373952.
TEST(DispersionFormula, HerzbergerByHand) {
    const std::vector<double> c = {1.5, 0.004, 0.0002, -0.001, 0.0001, -0.00001};
    EXPECT_NEAR(eval(F::Herzberger, c, std::sqrt(1.028)), 1.50326681466048, 1e-14);
}

// Conrady: n = n0 + A / l + B / l^3.5; at l = 1: 1.5 + 0.01 + 0.001; at l = 4 (4^3.5 = 128):
// 1.5 + 0.0025 + 0.001 / 128.
TEST(DispersionFormula, ConradyByHand) {
    const std::vector<double> c = {1.5, 0.01, 0.001};
    EXPECT_NEAR(eval(F::Conrady, c, 1.0), 1.511, 1e-15);
    EXPECT_NEAR(eval(F::Conrady, c, 4.0), 1.5025078125, 1e-15);
}

// Handbook of Optics 1: n^2 = A + B / (l^2 - C) - D l^2; at l = 1: 2 + 0.01 / 0.96 - 0.01.
// Handbook of Optics 2 is the same curve written with B l^2 / (l^2 - C) = B + B C / (l^2 - C):
// HoO2(A, B, C, D) = HoO1(A + B, B C, C, D).
TEST(DispersionFormula, HandbookOfOpticsByHandAndIdentity) {
    EXPECT_NEAR(eval(F::HandbookOfOptics1, {2.0, 0.01, 0.04, 0.01}, 1.0),
                std::sqrt(2.0 + 0.01 / 0.96 - 0.01), 1e-15);
    const double a = 2.1, b = 0.6, c = 0.02, d = 0.012;
    for (double l : {0.4, 0.6, 1.0, 2.0}) {
        EXPECT_NEAR(eval(F::HandbookOfOptics2, {a, b, c, d}, l),
                    eval(F::HandbookOfOptics1, {a + b, b * c, c, d}, l), 1e-14)
            << l;
    }
}

TEST(DispersionFormula, ExtendedFormulasReduceToSchott) {
    const std::vector<double> s = {2.2718929,    -1.0108077e-2, 1.0592509e-2,
                                   2.0816965e-4, -7.6472538e-6, 4.9240991e-7};
    const std::vector<double> ext1 = {s[0], s[1], s[2], s[3], s[4], s[5], 0.0, 0.0};
    const std::vector<double> ext2 = ext1;
    // Extended 3 puts l^4 third: a0 a1 [l^4] a2 a3 a4 a5 [l^-10] [l^-12].
    const std::vector<double> ext3 = {s[0], s[1], 0.0, s[2], s[3], s[4], s[5], 0.0, 0.0};
    for (double l : {0.35, 0.5875618, 1.0, 2.3}) {
        const double schott = eval(F::Schott, s, l);
        EXPECT_NEAR(eval(F::Extended1, ext1, l), schott, 1e-14) << l;
        EXPECT_NEAR(eval(F::Extended2, ext2, l), schott, 1e-14) << l;
        EXPECT_NEAR(eval(F::Extended3, ext3, l), schott, 1e-14) << l;
    }
}

TEST(DispersionFormula, MissingCoefficientsAreZeroExtraOnesIgnored) {
    EXPECT_DOUBLE_EQ(eval(F::Conrady, {1.5}, 0.7), 1.5);
    EXPECT_DOUBLE_EQ(eval(F::Conrady, {1.5, 0.0, 0.0, 99.0, 99.0}, 0.7), 1.5);
    // Schott reads six coefficients; a seventh (an Extended 1 term) changes nothing.
    std::vector<double> c = {2.0, 0.0, 0.01, 0.0, 0.0, 0.0, 5.0};
    EXPECT_DOUBLE_EQ(eval(F::Schott, c, 0.5), std::sqrt(2.04));
}

TEST(DispersionFormula, NanWhereTheSquareIsNotPositive) {
    EXPECT_TRUE(std::isnan(eval(F::Schott, {-1.0}, 0.5)));
    EXPECT_TRUE(std::isnan(eval(F::Sellmeier1, {-2.0, 0.0}, 0.5)));
    EXPECT_TRUE(std::isnan(eval(F::HandbookOfOptics1, {0.0}, 0.5)));
}

// Glass

TEST(Glass, IndexTakesNanometresAndTheAbbeNumberFollowsTheFormula) {
    const Glass g("N-BK7", "SCHOTT", F::Sellmeier1, kNbk7);
    EXPECT_NEAR(g.index(587.5618), 1.51680, 1e-5);
    // (nd - 1) / (nF - nC) from the data sheet's 1.516800, 1.522376, 1.514322 (6 decimals).
    EXPECT_NEAR(g.abbeNumber(), 0.5168 / (1.522376 - 1.514322), 0.01);
    EXPECT_NEAR(g.abbeNumber(), 64.17, 0.005);
}

TEST(Glass, InRangeUsesTheCatalogRange) {
    Glass g("X", "T", F::Sellmeier1, kNbk7);
    EXPECT_TRUE(g.inRange(100.0));  // unknown range: anything goes
    g.minWavelengthNm = 310.0;
    g.maxWavelengthNm = 2500.0;
    EXPECT_TRUE(g.inRange(310.0));
    EXPECT_TRUE(g.inRange(2500.0));
    EXPECT_FALSE(g.inRange(300.0));
    EXPECT_FALSE(g.inRange(2600.0));
}

TEST(Glass, WithCoefficientsKeepsTheRecord) {
    Glass g("X", "T", F::Sellmeier1, kNbk7);
    g.ndCatalog = 1.5168;
    g.comment = "kept";
    const Glass h = g.withCoefficients({1.0, 0.01});
    EXPECT_EQ(h.name(), "X");
    EXPECT_EQ(h.catalog(), "T");
    EXPECT_EQ(h.formula(), F::Sellmeier1);
    EXPECT_EQ(h.coefficients(), (std::vector<double>{1.0, 0.01}));
    EXPECT_EQ(h.ndCatalog, 1.5168);
    EXPECT_EQ(h.comment, "kept");
}

TEST(Glass, CatalogFieldsDefaultToUnknown) {
    const Glass g;
    EXPECT_TRUE(std::isnan(g.ndCatalog));
    EXPECT_TRUE(std::isnan(g.vdCatalog));
    EXPECT_TRUE(std::isnan(g.dPgF()));
    EXPECT_FALSE(g.internalTransmittance(500.0, 10.0));
    EXPECT_FALSE(g.absorptionPerMm(500.0));
}

TEST(Glass, Prints) {
    Glass g("N-BK7", "SCHOTT", F::Sellmeier1, kNbk7);
    g.ndCatalog = 1.5168;
    g.vdCatalog = 64.17;
    g.status = GlassStatus::Preferred;
    EXPECT_EQ(printed(g), "Glass{SCHOTT N-BK7, Sellmeier 1, nd=1.5168, vd=64.17, preferred}");
    EXPECT_EQ(printed(GlassStatus::Obsolete), "obsolete");
    EXPECT_EQ(printed(TransmittancePoint{400.0, 0.9, 10.0}),
              "TransmittancePoint{400 nm, tau=0.9 for 10 mm}");
    EXPECT_EQ(printed(AirConditions{}), "AirConditions{15 C, 101325 Pa, RH 0 %, CO2 450 ppm}");
}

// Model Glass

// Relative partial dispersion P_xy = (n_x - n_y) / (n_F - n_C).
double partial(const Glass& g, double xNm, double yNm) {
    return (g.index(xNm) - g.index(yNm)) / (g.index(kLineF) - g.index(kLineC));
}

TEST(Glass, ModelHasExactNdVdAndNormalPartialDispersions) {
    struct Case {
        double nd, vd, dPgF;
    };
    for (const Case& c : {Case{1.5168, 64.17, 0.0}, Case{1.80518, 25.43, 0.0},
                          Case{1.497, 81.61, 0.0375}, Case{1.6, 40.0, -0.01}}) {
        const Glass g = Glass::model(c.nd, c.vd, c.dPgF);
        EXPECT_NEAR(g.index(kLineD), c.nd, 1e-12);
        EXPECT_NEAR(g.abbeNumber(), c.vd, 1e-9);
        // Schott normal lines (SCHOTT TIE-29): P_gF = 0.6438 - 0.001682 vd (+ dPgF),
        // P_Ct = 0.5450 + 0.004743 vd.
        EXPECT_NEAR(partial(g, kLineG, kLineF), 0.6438 - 0.001682 * c.vd + c.dPgF, 1e-9);
        EXPECT_NEAR(partial(g, kLineC, kLineT), 0.5450 + 0.004743 * c.vd, 1e-9);
        EXPECT_EQ(g.formula(), F::Model);
        EXPECT_EQ(g.catalog(), "MODEL");
        EXPECT_EQ(g.ndCatalog, c.nd);
        EXPECT_EQ(g.vdCatalog, c.vd);
        EXPECT_EQ(g.dPgF(), c.dPgF);
    }
    EXPECT_EQ(Glass::model(1.5168, 64.17).name(), "1.5168/64.17");
    EXPECT_EQ(Glass::model(1.497, 81.61, 0.0375).name(), "1.497/81.61/0.0375");
}

// Not an exact identity: a sanity check that the model is a usable stand-in for a real
// glass. N-BK7's model (catalog nd, vd, dPgF = -0.0009) stays within 3e-4 of the catalog
// formula over 400..1000 nm.
TEST(Glass, ModelFollowsARealGlass) {
    const Glass real("N-BK7", "SCHOTT", F::Sellmeier1, kNbk7);
    const Glass model = Glass::model(1.5168, 64.17, -0.0009);
    for (double nm = 400.0; nm <= 1000.0; nm += 50.0)
        EXPECT_NEAR(model.index(nm), real.index(nm), 3e-4) << nm << " nm";
}

TEST(Glass, ModelRejectsNonsense) {
    EXPECT_THROW(Glass::model(1.5, -1.0), std::invalid_argument);
    EXPECT_THROW(Glass::model(1.5, std::nan("")), std::invalid_argument);
    EXPECT_THROW(Glass::model(std::nan(""), 60.0), std::invalid_argument);
    EXPECT_THROW(Glass::model(-1.0, 60.0), std::invalid_argument);
}

// Internal Transmittance

// A table with rows at 10 mm and one at 25 mm.
Glass withTable() {
    Glass g("T", "TEST", F::Sellmeier1, kNbk7);
    g.transmittance = {{400.0, 0.90, 10.0}, {500.0, 0.98, 10.0}, {600.0, 0.99, 25.0}};
    return g;
}

TEST(Glass, TransmittanceInterpolatesLinearlyAtTheTableThickness) {
    const Glass g = withTable();
    EXPECT_NEAR(*g.internalTransmittance(400.0, 10.0), 0.90, 1e-15);
    EXPECT_NEAR(*g.internalTransmittance(450.0, 10.0), 0.94, 1e-15);
    EXPECT_NEAR(*g.internalTransmittance(475.0, 10.0), 0.96, 1e-15);
}

// Beer-Lambert: tau(d) = tau(10 mm)^(d / 10), alpha = -ln tau(10 mm) / 10.
TEST(Glass, TransmittanceScalesWithThicknessByBeerLambert) {
    const Glass g = withTable();
    EXPECT_NEAR(*g.internalTransmittance(450.0, 25.0), 0.8566819844026136, 1e-14);  // 0.94^2.5
    EXPECT_NEAR(*g.internalTransmittance(450.0, 5.0), std::sqrt(0.94), 1e-14);
    EXPECT_NEAR(*g.absorptionPerMm(450.0), 0.006187540371808753, 1e-15);  // -ln(0.94) / 10
    EXPECT_NEAR(*g.internalTransmittance(450.0, 25.0), std::exp(-*g.absorptionPerMm(450.0) * 25),
                1e-14);
    EXPECT_EQ(*g.internalTransmittance(450.0, 0.0), 1.0);
}

// The 25 mm row is brought to 10 mm first: 0.99^(10/25) = 0.9959879355809816; at 550 nm
// tau(10 mm) = (0.98 + 0.9959879355809816) / 2.
TEST(Glass, TransmittanceRowsOfOtherThicknessAreConvertedFirst) {
    const Glass g = withTable();
    EXPECT_NEAR(*g.internalTransmittance(600.0, 10.0), 0.9959879355809816, 1e-15);
    EXPECT_NEAR(*g.internalTransmittance(600.0, 25.0), 0.99, 1e-15);
    EXPECT_NEAR(*g.internalTransmittance(550.0, 10.0), 0.9879939677904908, 1e-15);
    EXPECT_NEAR(*g.internalTransmittance(550.0, 25.0), 0.9702546493645557, 1e-14);
}

TEST(Glass, TransmittanceClampsAtTheTableEnds) {
    const Glass g = withTable();
    EXPECT_NEAR(*g.internalTransmittance(300.0, 10.0), 0.90, 1e-15);
    EXPECT_NEAR(*g.internalTransmittance(2000.0, 25.0), 0.99, 1e-15);
    EXPECT_NEAR(*g.absorptionPerMm(300.0), -std::log(0.90) / 10.0, 1e-15);
}

TEST(Glass, OpaqueRowsGiveInfiniteAbsorption) {
    Glass g = withTable();
    g.transmittance.insert(g.transmittance.begin(), {350.0, 0.0, 10.0});
    EXPECT_EQ(*g.internalTransmittance(350.0, 1.0), 0.0);
    EXPECT_EQ(*g.internalTransmittance(350.0, 0.0), 1.0);
    EXPECT_TRUE(std::isinf(*g.absorptionPerMm(350.0)));
    // Halfway to the 0.9 row the interpolated tau is 0.45.
    EXPECT_NEAR(*g.internalTransmittance(375.0, 10.0), 0.45, 1e-15);
}

TEST(Glass, TransmittanceRejectsNegativeThickness) {
    EXPECT_THROW(withTable().internalTransmittance(450.0, -1.0), std::invalid_argument);
}

// Air

// NIST Engineering Metrology Toolbox, "Refractive Index of Air Calculator" documentation,
// table of Ciddor-equation values for checking an implementation (CO2 450 ppm, vacuum
// wavelength): temperature C, pressure kPa, relative humidity %, wavelength nm, n.
TEST(AirIndex, ReproducesTheNistCiddorTable) {
    struct Row {
        double t, pKPa, rh, nm, n;
    };
    const Row rows[] = {
        {20, 101.325, 0, 633, 1.000271800},  {20, 60, 0, 633, 1.000160924},
        {20, 120, 0, 633, 1.000321916},      {50, 100, 0, 633, 1.000243285},
        {5, 100, 0, 633, 1.000282756},       {-40, 100, 0, 633, 1.000337580},
        {50, 120, 100, 633, 1.000287924},    {40, 120, 75, 633, 1.000299418},
        {20, 100, 100, 633, 1.000267394},    {40, 110, 100, 1700, 1.000270247},
        {20, 101.325, 0, 1700, 1.000268479}, {40, 110, 100, 300, 1.000289000},
        {20, 101.325, 0, 300, 1.000286581},  {-40, 120, 0, 300, 1.000427233},
    };
    for (const Row& r : rows) {
        const AirConditions air{r.t, r.pKPa * 1e3, r.rh / 100.0, 450.0};
        EXPECT_NEAR(airIndex(r.nm, air), r.n, 1e-9) << air << " at " << r.nm << " nm";
    }
}

// Standard air is where Ciddor's dispersion formula applies directly:
// (n - 1) 1e8 = 5792105 / (238.0185 - s^2) + 167917 / (57.362 - s^2), s = 1 / lambda um.
// At 633 nm, s^2 = 2.4957...: n = 1.00027653 (hand-evaluated: 1.0002765302).
TEST(AirIndex, StandardAirFollowsCiddorsDispersionFormula) {
    EXPECT_NEAR(airIndex(633.0), 1.0002765302, 1e-10);
    EXPECT_EQ(airIndex(633.0), airIndex(633.0, AirConditions{}));
    // Drier, warmer, thinner air has a lower index; more CO2 a higher one.
    const AirConditions ref = AirConditions::catalogReference();
    EXPECT_EQ(ref.temperatureC, 20.0);
    EXPECT_EQ(ref.pressurePa, 101325.0);
    EXPECT_LT(airIndex(587.5618, ref), airIndex(587.5618));
    EXPECT_GT(airIndex(587.5618, {15.0, 101325.0, 0.0, 800.0}), airIndex(587.5618));
    // Normal dispersion: blue above red.
    EXPECT_GT(airIndex(400.0), airIndex(700.0));
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// A CODE V private glass (US patent lens 65988's 'E48', its PRV table): exact at its points,
// and between them the natural cubic spline over 1 / lambda^2, checked against SciPy's
// CubicSpline(bc_type='natural') through the same points (values printed to 17 digits).
TEST(GlassTable, ExactAtItsPointsAndTheNaturalSplineBetween) {
    const std::vector<double> nm = {1600, 1500, 1400,  1300,  1200,  1100, 1000, 900, 800,   700,
                                    650,  600,  587.6, 546.1, 486.1, 480,  460,  440, 404.7, 400};
    const std::vector<double> n = {1.5184, 1.5188, 1.5192, 1.5197, 1.5201, 1.5219,  1.5231,
                                   1.5247, 1.5257, 1.527,  1.5286, 1.5306, 1.53116, 1.5334,
                                   1.5378, 1.5384, 1.5404, 1.5427, 1.5476, 1.5484};
    const Glass g = Glass::table("E48", nm, n);
    EXPECT_EQ(g.formula(), DispersionFormula::Table);
    for (size_t i = 0; i < nm.size(); ++i) EXPECT_NEAR(g.index(nm[i]), n[i], 1e-14) << nm[i];
    EXPECT_NEAR(g.index(587.5618), 1.5311617964888755, 1e-13);
    EXPECT_NEAR(g.index(656.2725), 1.5283672458025532, 1e-13);
    EXPECT_NEAR(g.index(486.1327), 1.5377968587325785, 1e-13);
    EXPECT_NEAR(g.index(620.0), 1.5297624405535333, 1e-13);
    EXPECT_NEAR(g.ndCatalog, 1.5311617964888755, 1e-13);
    EXPECT_TRUE(g.inRange(400.0));
    EXPECT_FALSE(g.inRange(380.0));
    // Beyond the ends: straight in 1 / lambda^2, continuing the spline's end slope.
    const double x0 = 1.0 / (1.6 * 1.6), x = 1.0 / (1.7 * 1.7);
    const double h = 1e-6;
    const double slope = (g.index(1e3 / std::sqrt(x0 + h)) - g.index(1600.0)) / h;
    EXPECT_NEAR(g.index(1700.0), 1.5184 + slope * (x - x0), 1e-8);
    EXPECT_LT(g.index(1700.0), 1.5184);
}

// A table drawn from a smooth glass reproduces it between its points: N-BK7's Sellmeier
// (Schott data sheet) at 12 points over 400-1000 nm, checked at the midpoints: 6.6e-6 in the
// end segments, where the natural spline's straight ends bend least like the glass (SciPy's
// natural spline gives the same errors), 1.6e-6 or less inside.
TEST(GlassTable, ATableOfASmoothGlassFollowsItBetweenThePoints) {
    const std::vector<double> k = {1.03961212,    6.00069867e-3, 0.231792344,
                                   2.00179144e-2, 1.01046945,    103.560653};
    auto bk7 = [&](double nmValue) {
        return evaluateDispersion(DispersionFormula::Sellmeier1, k, nmValue * 1e-3);
    };
    std::vector<double> nm, n;
    for (int i = 0; i < 12; ++i) {
        nm.push_back(400.0 + 600.0 * i / 11.0);
        n.push_back(bk7(nm.back()));
    }
    const Glass g = Glass::table("BK7 table", nm, n);
    double worst = 0.0;
    for (int i = 0; i + 1 < 12; ++i) {
        const double mid = 0.5 * (nm[i] + nm[i + 1]);
        worst = std::max(worst, std::abs(g.index(mid) - bk7(mid)));
    }
    EXPECT_LT(worst, 7e-6);
    EXPECT_LT(std::abs(g.index(0.5 * (nm[5] + nm[6])) - bk7(0.5 * (nm[5] + nm[6]))), 2e-7);
    EXPECT_NEAR(g.abbeNumber(), (bk7(kLineD) - 1.0) / (bk7(kLineF) - bk7(kLineC)), 0.01);
}

TEST(GlassTable, BadTablesAreRefused) {
    EXPECT_THROW(Glass::table("a", {500.0}, {1.5}), std::invalid_argument);
    EXPECT_THROW(Glass::table("a", {500.0, 600.0}, {1.5}), std::invalid_argument);
    EXPECT_THROW(Glass::table("a", {500.0, 500.0}, {1.5, 1.51}), std::invalid_argument);
    EXPECT_THROW(Glass::table("a", {500.0, -600.0}, {1.5, 1.49}), std::invalid_argument);
    EXPECT_THROW(Glass::table("a", {500.0, 600.0}, {1.5, 0.0}), std::invalid_argument);
    // Given in any order: sorted by wavelength.
    const Glass g = Glass::table("a", {600.0, 500.0}, {1.49, 1.5});
    EXPECT_EQ(g.coefficients(), (std::vector<double>{500.0, 1.5, 600.0, 1.49}));
}

}  // namespace
}  // namespace veil
