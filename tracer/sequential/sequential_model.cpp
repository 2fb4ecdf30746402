#include "tracer/sequential/sequential_model.h"

#include <cmath>
#include <optional>

#include "geometry/surface_frames.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const SequentialSurface& s) {
    os << "SequentialSurface{" << s.name << " z=" << s.zMm << " " << s.shape;
    if (s.clearSemiDiameterMm > 0.0) os << " sd=" << s.clearSemiDiameterMm;
    if (s.innerSemiDiameterMm > 0.0) os << " hole=" << s.innerSemiDiameterMm;
    if (s.mirror) os << " mirror";
    if (s.stop) os << " stop";
    return os << "}";
}

SequentialModel SequentialModel::build(const Prescription& p, const GlassCatalog& catalog) {
    std::vector<double> wl;
    for (const Wavelength& w : p.system.wavelengths) wl.push_back(w.nm);
    if (wl.empty()) wl.push_back(kLineD);
    SequentialModel m = build(p, catalog, wl);
    if (!p.system.wavelengths.empty()) m.primaryWavelength_ = p.system.primaryWavelength;
    return m;
}

SequentialModel SequentialModel::build(const Prescription& p, const GlassCatalog& catalog,
                                       const std::vector<double>& wavelengthsNm) {
    p.validate();
    SequentialModel m;
    m.prescription_ = p;
    m.wavelengthsNm_ = wavelengthsNm;
    m.primaryWavelength_ = 0;
    m.stopIndex_ = p.stopIndex();

    const int n = static_cast<int>(p.surfaces.size());
    const std::vector<Frame> frames = surfaceFrames(p);
    // Only surfaces light meets decide whether the model is coaxial.
    m.coaxial_ = firstSurfaceOffAxis(p, frames) < 0;
    double z = 0.0;
    for (int i = 0; i < n; ++i) {
        const Surface& s = p.surfaces[i];
        SequentialSurface seq;
        seq.name = s.name;
        seq.coordinateBreak = s.coordinateBreak.has_value();
        seq.frame = frames[i];
        seq.rotated = frames[i].rotation != glm::dmat3(1.0);
        seq.shape = surfaceShape(s);
        seq.clearSemiDiameterMm = s.clearSemiDiameterMm;
        seq.mirror = s.mirror;
        seq.stop = i == m.stopIndex_;
        seq.vignettes = s.clearSemiDiameterMm > 0.0 && !s.semiDiameterAutomatic && !seq.stop;
        seq.innerSemiDiameterMm = s.innerSemiDiameterMm;
        if (i == 0) {
            // The object plane sits one object distance in front of surface 1.
            seq.zMm = std::isfinite(s.thicknessMm) ? -s.thicknessMm : -kInfinity;
        } else {
            seq.zMm = z;
            z += s.thicknessMm;
        }
        m.surfaces_.push_back(seq);
    }

    // Propagation direction per gap: flips at every mirror.
    m.directions_.assign(n, 1.0);
    double dir = 1.0;
    for (int i = 0; i < n; ++i) {
        if (p.surfaces[i].mirror) dir = -dir;
        m.directions_[i] = dir;
    }

    // Glasses, resolved once per gap.
    std::vector<std::optional<Glass>> glasses(n);
    for (int i = 0; i < n; ++i) {
        const Material& mat = p.surfaces[i].material;
        switch (mat.kind) {
            case Material::Kind::Air:
                break;
            case Material::Kind::Model:
            case Material::Kind::Table:
            case Material::Kind::Formula:
                glasses[i] = mat.ownGlass();
                break;
            case Material::Kind::Catalog: {
                const Glass* g = catalog.find(mat.name, p.system.glassCatalogs);
                if (!g) {
                    std::string msg = "unknown glass '" + mat.name + "'";
                    auto sug = catalog.suggestions(mat.name);
                    if (!sug.empty()) {
                        msg += " (did you mean";
                        for (size_t k = 0; k < sug.size(); ++k) msg += (k ? ", " : " ") + sug[k];
                        msg += "?)";
                    }
                    throw ModelError(p.surfaces[i].name, msg);
                }
                glasses[i] = *g;
                break;
            }
        }
    }
    for (double wl : wavelengthsNm) {
        std::vector<double> row(n, 1.0);
        for (int i = 0; i < n; ++i) {
            double idx = glasses[i] ? glasses[i]->index(wl) : 1.0;
            if (!(idx >= 1.0 || (idx > 0.0 && glasses[i])) || !std::isfinite(idx))
                throw ModelError(p.surfaces[i].name, "index of " + p.surfaces[i].material.label() +
                                                         " is undefined at " + std::to_string(wl) +
                                                         " nm");
            row[i] = idx * m.directions_[i];
        }
        m.indices_.push_back(std::move(row));
    }
    return m;
}

double SequentialModel::thicknessMm(int gap) const {
    return prescription_.surfaces[gap].thicknessMm;
}

bool SequentialModel::objectAtInfinity() const {
    return !std::isfinite(prescription_.surfaces[0].thicknessMm);
}

}  // namespace veil
