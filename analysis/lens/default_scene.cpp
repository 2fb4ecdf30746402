#include "analysis/lens/default_scene.h"

#include <cmath>
#include <numbers>
#include <sstream>

#include "analysis/lens/first_order.h"
#include "geometry/mechanics.h"
#include "geometry/numerics.h"
#include "lensdata/glass_catalog.h"
#include "tracer/light/spectrum.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

namespace {

std::vector<Source> fieldSources(const SceneSpec& file, const GlassCatalog& catalog,
                                 const std::vector<std::pair<double, double>>& fields) {
    const std::shared_ptr<const SequentialModel> built =
        file.model ? file.model
                   : std::make_shared<const SequentialModel>(
                         SequentialModel::build(file.prescription, catalog));
    const SequentialModel& model = *built;
    const EntranceAperture ap = entranceAperture(file.prescription, model);
    std::vector<Wavelength> lines = file.prescription.system.wavelengths;
    if (lines.empty()) lines.push_back({kLineD, 1.0});
    std::vector<Source> out;
    for (size_t f = 0; f < fields.size(); ++f) {
        std::ostringstream name;
        name << "field" << f + 1;
        SpectralSampler spectrum(lines, FluxUnit::Watt, name.str());
        if (model.objectAtInfinity()) {
            checkFieldAngles(fields[f].first, fields[f].second, "field " + std::to_string(f + 1));
            const Vec3 d = fieldDirection(fields[f].first, fields[f].second);
            BeamOptions o;
            const Beam beam = beamFillingAperture(ap, d, o);
            // 1 W through the first surface's aperture disk, as [[source]] does by default.
            const double irradiance =
                1.0 / (kPi * beam.apertureRadiusMm * beam.apertureRadiusMm * d.z);
            out.emplace_back(name.str(), CollimatedSource{beam}, irradiance * beam.areaMm2(),
                             spectrum);
        } else {
            const double zObject = -file.prescription.surfaces[0].thicknessMm;
            const Vec3 pos(fields[f].first, fields[f].second, zObject);
            const PointSource ps = pointSourceCoveringAperture(ap, pos, 0.0);
            out.emplace_back(name.str(), ps, 1.0, spectrum);
        }
    }
    return out;
}

}  // namespace

void setFieldSources(SceneSpec& file, const GlassCatalog& catalog,
                     const std::vector<std::pair<double, double>>& fieldsDeg) {
    file.sources = fieldSources(file, catalog, fieldsDeg);
}

std::vector<std::pair<double, double>> addSystemFieldSources(SceneSpec& file,
                                                             const GlassCatalog& catalog) {
    if (!file.sources.empty()) return {};
    std::vector<std::pair<double, double>> fields;
    for (const Field& f : file.prescription.system.fields) fields.emplace_back(f.x, f.y);
    if (fields.empty()) fields.emplace_back(0.0, 0.0);
    file.sources = fieldSources(file, catalog, fields);
    return fields;
}

bool addDefaultGhostScene(SceneSpec& file, const GlassCatalog& catalog, double* imageShiftMm) {
    if (imageShiftMm) *imageShiftMm = 0.0;
    if (!file.sources.empty()) return false;
    // The detector at the paraxial image plane of the primary wavelength (an afocal lens
    // keeps its image surface).
    {
        if (!file.model)
            file.model = std::make_shared<const SequentialModel>(
                SequentialModel::build(file.prescription, catalog));
        const SequentialModel& model = *file.model;
        const double dz =
            computeFirstOrder(model, model.primaryWavelength()).paraxialImageDistanceMm;
        if (std::isfinite(dz) && dz != 0.0) {
            file.prescription.surfaces[model.imageIndex() - 1].thicknessMm += dz;
            // The prescription changed: its model is built anew, once.
            file.model = std::make_shared<const SequentialModel>(
                SequentialModel::build(file.prescription, catalog));
            if (imageShiftMm) *imageShiftMm = dz;
        }
    }
    std::vector<std::pair<double, double>> fields;
    for (const Field& f : file.prescription.system.fields) fields.emplace_back(f.x, f.y);
    if (fields.empty()) fields.emplace_back(0.0, 0.0);
    file.sources = fieldSources(file, catalog, fields);
    // The stop plate, unless a coordinate break takes the lens off one axis or a surface is
    // anamorphic (the mount generator builds about one axis, on rims of revolution): the
    // stop's sd then clips sequential rays alone.
    if (!file.mechanics && file.model->coaxial() && file.prescription.firstAnamorphic() < 0) {
        MechanicsSpec m;
        m.barrel.enabled = false;
        m.retainers.enabled = false;
        m.spacers.enabled = false;
        m.stop.enabled = true;
        file.mechanics = m;
    }
    return true;
}

std::unique_ptr<PreparedScene> prepareTracedScene(
    SceneSpec file, const GlassCatalog& catalog,
    const std::vector<std::pair<double, double>>& fieldsDeg, const SceneOptions& options,
    std::string* note) {
    if (note) note->clear();
    if (!fieldsDeg.empty()) {
        setFieldSources(file, catalog, fieldsDeg);
    } else if (file.sources.empty()) {
        const auto used = addSystemFieldSources(file, catalog);
        const bool angle = file.prescription.system.fieldKind == SystemData::FieldKind::AngleDeg;
        if (note) {
            std::ostringstream os;
            os << file.path.string() << " has no [[source]]: tracing one "
               << (angle ? "collimated beam" : "point source") << " per system field (";
            for (size_t k = 0; k < used.size(); ++k)
                os << (k ? "; " : "") << used[k].first << "," << used[k].second;
            os << (angle ? " deg" : " mm")
               << "; 1 W through the first surface); add [[source]] (docs/format.md) or --field "
                  "X,Y to choose";
            *note = os.str();
        }
    }
    return PreparedScene::build(std::move(file), catalog, options);
}

}  // namespace veil
