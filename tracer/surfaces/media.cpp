#include "tracer/surfaces/media.h"

#include <cmath>
#include <optional>

#include "geometry/scene.h"
#include "lensdata/glass_catalog.h"

namespace veil {

MediaOptics::MediaOptics(const Scene& scene, const GlassCatalog& catalog,
                         const std::vector<std::string>& preferredCatalogs,
                         const std::vector<double>& wavelengthsNm)
    : wavelengthsNm_(wavelengthsNm) {
    for (const Medium& m : scene.media()) {
        std::optional<Glass> glass;
        switch (m.material.kind) {
            case Material::Kind::Air:
                break;
            case Material::Kind::Model:
            case Material::Kind::Table:
            case Material::Kind::Formula:
                glass = m.material.ownGlass();
                break;
            case Material::Kind::Catalog: {
                const Glass* g = catalog.find(m.material.name, preferredCatalogs);
                if (!g) throw ModelError(m.name, "unknown glass '" + m.material.name + "'");
                glass = *g;
                break;
            }
        }
        std::vector<double> n, a;
        for (double wl : wavelengthsNm) {
            const double idx = glass ? glass->index(wl) : 1.0;
            if (!(idx > 0.0) || !std::isfinite(idx))
                throw ModelError(m.name, "index undefined at " + std::to_string(wl) + " nm");
            n.push_back(idx);
            a.push_back(glass ? glass->absorptionPerMm(wl).value_or(0.0) : 0.0);
        }
        index_.push_back(std::move(n));
        alpha_.push_back(std::move(a));
    }
}

}  // namespace veil
