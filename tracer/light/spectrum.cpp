#include "tracer/light/spectrum.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace veil {

namespace {

// CIE photopic luminous efficiency function V(lambda), 360 to 830 nm in 1 nm steps.
// Source: the CIE 1 nm table of V(lambda) (CIE 018:2019 "The Basis of Physical Photometry",
// 3rd ed.; ISO 23539:2005 / CIE S 010/E:2004 "Photometry - The CIE system of physical
// photometry"), which is also the y-bar(lambda) column of the CIE 1931 standard observer at
// 1 nm (CIE 15:2004, Table T.4; CIE 018:2019). At every multiple of 5 nm it equals the
// CIE 1924 V(lambda) values; the 1 nm entries in between are the CIE's own interpolation.
// Typed in from the published table and checked against two public transcriptions (they
// differ at 547 nm, where the CIE value 0.9874182 is the smooth one; one transcription
// swaps two digits). The row comment gives the wavelength of the first entry.
constexpr double kVLambda[] = {
    0.000003917,
    0.000004393581,
    0.000004929604,
    0.000005532136,
    0.000006208245,  // 360
    0.000006965,
    0.000007813219,
    0.000008767336,
    0.000009839844,
    0.00001104323,  // 365
    0.00001239,
    0.00001388641,
    0.00001555728,
    0.00001744296,
    0.00001958375,  // 370
    0.00002202,
    0.00002483965,
    0.00002804126,
    0.00003153104,
    0.00003521521,  // 375
    0.000039,
    0.0000428264,
    0.0000469146,
    0.0000515896,
    0.0000571764,  // 380
    0.000064,
    0.00007234421,
    0.00008221224,
    0.00009350816,
    0.0001061361,  // 385
    0.00012,
    0.000134984,
    0.000151492,
    0.000170208,
    0.000191816,  // 390
    0.000217,
    0.0002469067,
    0.00028124,
    0.00031852,
    0.0003572667,  // 395
    0.000396,
    0.0004337147,
    0.000473024,
    0.000517876,
    0.0005722187,  // 400
    0.00064,
    0.00072456,
    0.0008255,
    0.00094116,
    0.00106988,  // 405
    0.00121,
    0.001362091,
    0.001530752,
    0.001720368,
    0.001935323,  // 410
    0.00218,
    0.0024548,
    0.002764,
    0.0031178,
    0.0035264,  // 415
    0.004,
    0.00454624,
    0.00515932,
    0.00582928,
    0.00654616,  // 420
    0.0073,
    0.008086507,
    0.00890872,
    0.00976768,
    0.01066443,  // 425
    0.0116,
    0.01257317,
    0.01358272,
    0.01462968,
    0.01571509,  // 430
    0.01684,
    0.01800736,
    0.01921448,
    0.02045392,
    0.02171824,  // 435
    0.023,
    0.02429461,
    0.02561024,
    0.02695857,
    0.02835125,  // 440
    0.0298,
    0.03131083,
    0.03288368,
    0.03452112,
    0.03622571,  // 445
    0.038,
    0.03984667,
    0.041768,
    0.043766,
    0.04584267,  // 450
    0.048,
    0.05024368,
    0.05257304,
    0.05498056,
    0.05745872,  // 455
    0.06,
    0.06260197,
    0.06527752,
    0.06804208,
    0.07091109,  // 460
    0.0739,
    0.077016,
    0.0802664,
    0.0836668,
    0.0872328,  // 465
    0.09098,
    0.09491755,
    0.09904584,
    0.1033674,
    0.1078846,  // 470
    0.1126,
    0.117532,
    0.1226744,
    0.1279928,
    0.1334528,  // 475
    0.13902,
    0.1446764,
    0.1504693,
    0.1564619,
    0.1627177,  // 480
    0.1693,
    0.1762431,
    0.1835581,
    0.1912735,
    0.199418,  // 485
    0.20802,
    0.2171199,
    0.2267345,
    0.2368571,
    0.2474812,  // 490
    0.2586,
    0.2701849,
    0.2822939,
    0.2950505,
    0.308578,  // 495
    0.323,
    0.3384021,
    0.3546858,
    0.3716986,
    0.3892875,  // 500
    0.4073,
    0.4256299,
    0.4443096,
    0.4633944,
    0.4829395,  // 505
    0.503,
    0.5235693,
    0.544512,
    0.56569,
    0.5869653,  // 510
    0.6082,
    0.6293456,
    0.6503068,
    0.6708752,
    0.6908424,  // 515
    0.71,
    0.7281852,
    0.7454636,
    0.7619694,
    0.7778368,  // 520
    0.7932,
    0.8081104,
    0.8224962,
    0.8363068,
    0.8494916,  // 525
    0.862,
    0.8738108,
    0.8849624,
    0.8954936,
    0.9054432,  // 530
    0.9148501,
    0.9237348,
    0.9320924,
    0.9399226,
    0.9472252,  // 535
    0.954,
    0.9602561,
    0.9660074,
    0.9712606,
    0.9760225,  // 540
    0.9803,
    0.9840924,
    0.9874182,
    0.9903128,
    0.9928116,  // 545
    0.9949501,
    0.9967108,
    0.9980983,
    0.999112,
    0.9997482,  // 550
    1,
    0.9998567,
    0.9993046,
    0.9983255,
    0.9968987,  // 555
    0.995,
    0.9926005,
    0.9897426,
    0.9864444,
    0.9827241,  // 560
    0.9786,
    0.9740837,
    0.9691712,
    0.9638568,
    0.9581349,  // 565
    0.952,
    0.9454504,
    0.9384992,
    0.9311628,
    0.9234576,  // 570
    0.9154,
    0.9070064,
    0.8982772,
    0.8892048,
    0.8797816,  // 575
    0.87,
    0.8598613,
    0.849392,
    0.838622,
    0.8275813,  // 580
    0.8163,
    0.8047947,
    0.793082,
    0.781192,
    0.7691547,  // 585
    0.757,
    0.7447541,
    0.7324224,
    0.7200036,
    0.7074965,  // 590
    0.6949,
    0.6822192,
    0.6694716,
    0.6566744,
    0.6438448,  // 595
    0.631,
    0.6181555,
    0.6053144,
    0.5924756,
    0.5796379,  // 600
    0.5668,
    0.5539611,
    0.5411372,
    0.5283528,
    0.5156323,  // 605
    0.503,
    0.4904688,
    0.4780304,
    0.4656776,
    0.4534032,  // 610
    0.4412,
    0.42908,
    0.417036,
    0.405032,
    0.393032,  // 615
    0.381,
    0.3689184,
    0.3568272,
    0.3447768,
    0.3328176,  // 620
    0.321,
    0.3093381,
    0.2978504,
    0.2865936,
    0.2756245,  // 625
    0.265,
    0.2547632,
    0.2448896,
    0.2353344,
    0.2260528,  // 630
    0.217,
    0.2081616,
    0.1995488,
    0.1911552,
    0.1829744,  // 635
    0.175,
    0.1672235,
    0.1596464,
    0.1522776,
    0.1451259,  // 640
    0.1382,
    0.1315003,
    0.1250248,
    0.1187792,
    0.1127691,  // 645
    0.107,
    0.1014762,
    0.09618864,
    0.09112296,
    0.08626485,  // 650
    0.0816,
    0.07712064,
    0.07282552,
    0.06871008,
    0.06476976,  // 655
    0.061,
    0.05739621,
    0.05395504,
    0.05067376,
    0.04754965,  // 660
    0.04458,
    0.04175872,
    0.03908496,
    0.03656384,
    0.03420048,  // 665
    0.032,
    0.02996261,
    0.02807664,
    0.02632936,
    0.02470805,  // 670
    0.0232,
    0.02180077,
    0.02050112,
    0.01928108,
    0.01812069,  // 675
    0.017,
    0.01590379,
    0.01483718,
    0.01381068,
    0.01283478,  // 680
    0.01192,
    0.01106831,
    0.01027339,
    0.009533311,
    0.008846157,  // 685
    0.00821,
    0.007623781,
    0.007085424,
    0.006591476,
    0.006138485,  // 690
    0.005723,
    0.005343059,
    0.004995796,
    0.004676404,
    0.004380075,  // 695
    0.004102,
    0.003838453,
    0.003589099,
    0.003354219,
    0.003134093,  // 700
    0.002929,
    0.002738139,
    0.002559876,
    0.002393244,
    0.002237275,  // 705
    0.002091,
    0.001953587,
    0.00182458,
    0.00170358,
    0.001590187,  // 710
    0.001484,
    0.001384496,
    0.001291268,
    0.001204092,
    0.001122744,  // 715
    0.001047,
    0.0009765896,
    0.0009111088,
    0.0008501332,
    0.0007932384,  // 720
    0.00074,
    0.0006900827,
    0.00064331,
    0.000599496,
    0.0005584547,  // 725
    0.00052,
    0.0004839136,
    0.0004500528,
    0.0004183452,
    0.0003887184,  // 730
    0.0003611,
    0.0003353835,
    0.0003114404,
    0.0002891656,
    0.0002684539,  // 735
    0.0002492,
    0.0002313019,
    0.0002146856,
    0.0001992884,
    0.0001850475,  // 740
    0.0001719,
    0.0001597781,
    0.0001486044,
    0.0001383016,
    0.0001287925,  // 745
    0.00012,
    0.0001118595,
    0.0001043224,
    0.0000973356,
    0.00009084587,  // 750
    0.0000848,
    0.00007914667,
    0.000073858,
    0.000068916,
    0.00006430267,  // 755
    0.00006,
    0.00005598187,
    0.0000522256,
    0.0000487184,
    0.00004544747,  // 760
    0.0000424,
    0.00003956104,
    0.00003691512,
    0.00003444868,
    0.00003214816,  // 765
    0.00003,
    0.00002799125,
    0.00002611356,
    0.00002436024,
    0.00002272461,  // 770
    0.0000212,
    0.00001977855,
    0.00001845285,
    0.00001721687,
    0.00001606459,  // 775
    0.00001499,
    0.00001398728,
    0.00001305155,
    0.00001217818,
    0.00001136254,  // 780
    0.0000106,
    0.000009885877,
    0.000009217304,
    0.000008592362,
    0.000008009133,  // 785
    0.0000074657,
    0.000006959567,
    0.000006487995,
    0.000006048699,
    0.000005639396,  // 790
    0.0000052578,
    0.000004901771,
    0.00000456972,
    0.000004260194,
    0.000003971739,  // 795
    0.0000037029,
    0.000003452163,
    0.000003218302,
    0.0000030003,
    0.000002797139,  // 800
    0.0000026078,
    0.00000243122,
    0.000002266531,
    0.000002113013,
    0.000001969943,  // 805
    0.0000018366,
    0.00000171223,
    0.000001596228,
    0.00000148809,
    0.000001387314,  // 810
    0.0000012934,
    0.00000120582,
    0.000001124143,
    0.000001048009,
    0.0000009770578,  // 815
    0.00000091093,
    0.0000008492513,
    0.0000007917212,
    0.0000007380904,
    0.0000006881098,  // 820
    0.00000064153,
    0.0000005980895,
    0.0000005575746,
    0.000000519808,
    0.0000004846123,  // 825
    0.00000045181,    // 830
};
constexpr int kVFirstNm = 360;
constexpr int kVCount = static_cast<int>(sizeof(kVLambda) / sizeof(kVLambda[0]));
static_assert(kVCount == 471, "V(lambda): 360 to 830 nm in 1 nm steps");

}  // namespace

const char* unitSymbol(FluxUnit u) { return u == FluxUnit::Watt ? "W" : "lm"; }

std::ostream& operator<<(std::ostream& os, FluxUnit u) { return os << unitSymbol(u); }

std::ostream& operator<<(std::ostream& os, SpectralSampling s) {
    return os << (s == SpectralSampling::Radiometric ? "radiometric" : "photometric");
}

double photopicEfficiency(double wavelengthNm) {
    const double x = wavelengthNm - kVFirstNm;
    if (!(x >= 0.0) || x > kVCount - 1) return 0.0;  // also NaN
    const int i = std::min(static_cast<int>(x), kVCount - 2);
    const double f = x - i;
    return kVLambda[i] + f * (kVLambda[i + 1] - kVLambda[i]);
}

// Spectral Sampler Method Definitions

SpectralSampler::SpectralSampler(std::vector<Wavelength> lines, FluxUnit unit,
                                 const std::string& owner)
    : SpectralSampler(
          std::move(lines), unit,
          unit == FluxUnit::Watt ? SpectralSampling::Radiometric : SpectralSampling::Photometric,
          owner) {}

SpectralSampler::SpectralSampler(std::vector<Wavelength> lines, FluxUnit unit,
                                 SpectralSampling sampling, const std::string& owner)
    : lines_(std::move(lines)), unit_(unit), sampling_(sampling) {
    if (lines_.empty()) throw ModelError(owner, "no wavelengths to emit");
    const int n = size();
    std::vector<double> radiant(n), luminous(n);
    double radiantSum = 0.0, luminousSum = 0.0;
    for (int i = 0; i < n; ++i) {
        const Wavelength& w = lines_[i];
        if (!std::isfinite(w.weight) || w.weight < 0.0 || !std::isfinite(w.nm) || w.nm <= 0.0) {
            std::ostringstream m;
            m << "wavelength " << i + 1 << " (" << w.nm << " nm, weight " << w.weight
              << ") is not a positive wavelength with a finite weight >= 0";
            throw ModelError(owner, m.str());
        }
        radiant[i] = w.weight;
        luminous[i] = w.weight * photopicEfficiency(w.nm);
        radiantSum += radiant[i];
        luminousSum += luminous[i];
    }
    if (radiantSum <= 0.0) throw ModelError(owner, "every wavelength has weight 0");
    efficacy_ = kMaxLuminousEfficacyLmPerW * luminousSum / radiantSum;
    const bool lumen = unit == FluxUnit::Lumen;
    const bool photometric = sampling == SpectralSampling::Photometric;
    if ((lumen || photometric) && luminousSum <= 0.0)
        throw ModelError(owner,
                         "no wavelength lies where the eye sees (V(lambda) > 0 only from 360 to "
                         "830 nm): a photometric source or photometric sampling has nothing "
                         "to emit");

    share_.resize(n);
    probability_.resize(n);
    double pSum = 0.0;
    for (int i = 0; i < n; ++i) {
        share_[i] = lumen ? luminous[i] / luminousSum : radiant[i] / radiantSum;
        probability_[i] = share_[i] > 0.0 ? (photometric ? luminous[i] : radiant[i]) : 0.0;
        if (share_[i] > 0.0 && probability_[i] <= 0.0) {
            std::ostringstream m;
            m << "photometric sampling never draws " << lines_[i].nm
              << " nm (V = 0 there) although it carries radiant flux; use radiometric "
                 "sampling";
            throw ModelError(owner, m.str());
        }
        pSum += probability_[i];
    }
    cumulative_.resize(n);
    double c = 0.0;
    for (int i = 0; i < n; ++i) {
        probability_[i] /= pSum;
        c += probability_[i];
        cumulative_[i] = c;
    }
    // The last line with a positive probability closes the distribution exactly, so no u in
    // [0, 1) falls past it through rounding.
    for (int i = n - 1; i >= 0; --i) {
        cumulative_[i] = 1.0;
        if (probability_[i] > 0.0) break;
    }
}

SpectralSampler::Sample SpectralSampler::sample(double u) const {
    // The first line whose cumulative probability exceeds u; lines with p = 0 share their
    // predecessor's cumulative value and are skipped by the strict comparison.
    u = std::clamp(u, 0.0, 0x1.fffffffffffffp-1);
    const auto it = std::upper_bound(cumulative_.begin(), cumulative_.end(), u);
    const int i = static_cast<int>(it - cumulative_.begin());
    return {i, lines_[i].nm, weight(i)};
}

std::ostream& operator<<(std::ostream& os, const SpectralSampler& s) {
    os << "SpectralSampler{" << s.unit() << ", " << s.sampling() << ",";
    for (int i = 0; i < s.size(); ++i)
        os << " " << s.lines()[i].nm << " nm (p " << s.probability(i) << ", share " << s.share(i)
           << ")";
    return os << "}";
}

}  // namespace veil
