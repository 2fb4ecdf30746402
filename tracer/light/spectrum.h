#pragma once
// Photometry and spectral sampling over the system wavelengths.
//
// A source's spectrum is the list of system wavelengths (nm, in air) with their weights, read
// as relative spectral power: line i carries a share w_i / sum(w) of the radiant flux (W).
// A photometric source (lm) counts the same lines through the eye: line i carries
// K_m V(lambda_i) w_i of luminous flux per unit of radiant weight, so its share of the lumen
// budget is w_i V_i / sum(w_j V_j).
//
// Each ray takes one line, drawn with probability p_i, and carries the flux weight
// share_i / p_i in the source's unit: its expected flux is then the source's flux whatever
// the p_i. The default draws p_i = share_i (weight 1 for every ray): radiometric sampling
// for a W source, photometric sampling (proportional to w_i V_i) for an lm source, so a lumen
// budget is spent where the eye sees. The other combination is allowed (weights differ from
// 1 but stay unbiased): for example an lm source that still traces its deep-red line.

#include <ostream>
#include <string>
#include <vector>

#include "lensdata/prescription.h"

namespace veil {

// The unit of a source's flux and of everything traced from it.
enum class FluxUnit { Watt, Lumen };
std::ostream& operator<<(std::ostream& os, FluxUnit u);  // "W", "lm"
const char* unitSymbol(FluxUnit u);

// Maximum luminous efficacy of radiation for photopic vision, K_m (lm/W), at 555 nm
// (the SI definition fixes 683 lm/W at 540e12 Hz, 555.016 nm in standard air).
inline constexpr double kMaxLuminousEfficacyLmPerW = 683.0;

// CIE 1924 photopic luminous efficiency V(lambda), lambda in nm (in air). Linear
// interpolation in the CIE 1 nm table from 360 to 830 nm; 0 outside. V(555) = 1.
double photopicEfficiency(double wavelengthNm);

// Luminous efficacy of monochromatic radiation K_m V(lambda), lm/W.
inline double luminousEfficacyLmPerW(double wavelengthNm) {
    return kMaxLuminousEfficacyLmPerW * photopicEfficiency(wavelengthNm);
}

// How the line of a ray is drawn: with probability proportional to w_i (radiometric) or to
// w_i V(lambda_i) (photometric).
enum class SpectralSampling { Radiometric, Photometric };
std::ostream& operator<<(std::ostream& os, SpectralSampling s);

class SpectralSampler {
  public:
    struct Sample {
        int index = 0;  // into the wavelength list (the model's wavelength index)
        double wavelengthNm = 0.0;
        double weight = 1.0;  // share / probability: multiplies totalFlux / rayCount
    };

    // `owner` names the source in errors. Lines whose share is zero (weight 0, or V = 0 for
    // an lm source) get probability 0: drawing them would only waste rays. Throws ModelError
    // when the list is empty, a weight is negative or not finite, no line has a positive
    // share (every weight zero; an lm source with every line outside 360-830 nm), or the
    // sampling cannot draw a line that carries flux (photometric sampling of a W source with
    // a line the eye does not see): that would bias the estimate.
    SpectralSampler(std::vector<Wavelength> lines, FluxUnit unit, SpectralSampling sampling,
                    const std::string& owner = "source");
    // Sampling that matches the unit: every ray has weight 1.
    SpectralSampler(std::vector<Wavelength> lines, FluxUnit unit,
                    const std::string& owner = "source");

    // u uniform in [0, 1).
    Sample sample(double u) const;

    int size() const { return static_cast<int>(lines_.size()); }
    const std::vector<Wavelength>& lines() const { return lines_; }
    FluxUnit unit() const { return unit_; }
    SpectralSampling sampling() const { return sampling_; }
    double probability(int i) const { return probability_[i]; }
    // Fraction of the source's flux (in its unit) that line i carries.
    double share(int i) const { return share_[i]; }
    double weight(int i) const { return probability_[i] > 0.0 ? share_[i] / probability_[i] : 0.0; }
    // Luminous efficacy of the whole spectrum, K_m sum(w V) / sum(w) (lm/W): converts the
    // source's radiant flux to luminous flux.
    double luminousEfficacyLmPerW() const { return efficacy_; }

  private:
    std::vector<Wavelength> lines_;
    FluxUnit unit_;
    SpectralSampling sampling_;
    std::vector<double> probability_;
    std::vector<double> share_;
    std::vector<double> cumulative_;  // cumulative_[i] = p_0 + ... + p_i; last = 1 exactly
    double efficacy_ = 0.0;
};
std::ostream& operator<<(std::ostream& os, const SpectralSampler& s);

}  // namespace veil
