#pragma once
// The optics of the scene's media at the traced wavelengths: refractive index (relative to
// air, as the catalogs give it) and the absorption coefficient from the catalog's internal
// transmittance data (0 when the catalog has none, and for air).

#include <string>
#include <vector>

namespace veil {

class Scene;
class GlassCatalog;

class MediaOptics {
  public:
    // Resolves every medium of the scene; throws ModelError naming the medium for an unknown
    // glass or an index undefined at one of the wavelengths.
    MediaOptics(const Scene& scene, const GlassCatalog& catalog,
                const std::vector<std::string>& preferredCatalogs,
                const std::vector<double>& wavelengthsNm);

    double index(int medium, int wavelength) const { return index_[medium][wavelength]; }
    // Absorption coefficient alpha (1/mm): the flux after a path of length d is exp(-alpha d).
    double absorptionPerMm(int medium, int wavelength) const { return alpha_[medium][wavelength]; }
    int wavelengthCount() const { return static_cast<int>(wavelengthsNm_.size()); }
    double wavelengthNm(int w) const { return wavelengthsNm_[w]; }

  private:
    std::vector<double> wavelengthsNm_;
    std::vector<std::vector<double>> index_;  // [medium][wavelength]
    std::vector<std::vector<double>> alpha_;  // [medium][wavelength]
};

}  // namespace veil
