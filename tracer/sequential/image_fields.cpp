#include "tracer/sequential/image_fields.h"

#include <cmath>
#include <sstream>
#include <string>

#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/pupil.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {

namespace {

constexpr double kDeg = M_PI / 180.0;

// The paraxial image height of the field parameter 1 (tan(angle) = 1, or a 1 mm object
// height) at the paraxial image plane, primary wavelength.
double paraxialHeightPerUnit(const SequentialModel& model) {
    const int w = model.primaryWavelength();
    const int last = model.imageIndex() - 1;
    const double n0 = model.index(0, w);
    const double nk = model.index(last, w);
    const PupilData pupil = computePupil(model, w);
    const double zLast = model.surface(last).zMm;
    double zPlane = 0.0;
    if (model.objectAtInfinity()) {
        const ParaxialMatrix m = paraxialMatrix(model, w, 1, last);
        if (m.c == 0.0) return 0.0;  // afocal
        zPlane = zLast + m.a * nk / -m.c;
    } else {
        const ParaxialRay marginal =
            traceParaxial(model, w, 1, last, pupil.marginalY1, pupil.marginalNu0);
        const double uk = marginal.nu[last] / nk;
        if (uk == 0.0) return 0.0;
        zPlane = zLast - marginal.y[last] / uk;
    }
    const double zE = pupil.entrancePupilZMm;
    double y1 = 0.0, nu0 = 0.0;
    if (model.objectAtInfinity()) {
        nu0 = n0;  // u0 = tan(angle) = 1
        y1 = std::isfinite(zE) ? -zE : 0.0;
    } else {
        const double t0 = model.thicknessMm(0);
        const double u0 = -1.0 / (zE + t0);  // from (1 mm, -t0) to (0, zE)
        nu0 = n0 * u0;
        y1 = 1.0 + u0 * t0;
    }
    const ParaxialRay chief = traceParaxial(model, w, 1, last, y1, nu0);
    return chief.y[last] + (zPlane - zLast) * chief.nu[last] / nk;
}

// The object-space field of parameter t along the unit azimuth (ux, uy).
Field fieldAt(bool angle, double t, double ux, double uy) {
    Field f;
    if (angle) {
        f.x = std::atan(t * ux) / kDeg;
        f.y = std::atan(t * uy) / kDeg;
    } else {
        f.x = t * ux;
        f.y = t * uy;
    }
    return f;
}

}  // namespace

Prescription resolveImageHeightFields(const Prescription& p, const GlassCatalog& catalog) {
    using Kind = SystemData::FieldKind;
    const Kind kind = p.system.fieldKind;
    if (kind != Kind::ParaxialImageHeightMm && kind != Kind::RealImageHeightMm) return p;
    Prescription out = p;
    const bool real = kind == Kind::RealImageHeightMm;
    // The model in the object-space kind the fields become.
    Prescription objectSpace = p;
    const bool infinite = std::isinf(p.surfaces[0].thicknessMm);
    objectSpace.system.fieldKind = infinite ? Kind::AngleDeg : Kind::ObjectHeightMm;
    objectSpace.system.fields = {Field{}};
    const SequentialModel model = SequentialModel::build(objectSpace, catalog);
    const double perUnit = paraxialHeightPerUnit(model);
    const std::string what = real ? "real image height" : "paraxial image height";
    if (!(std::abs(perUnit) > 0.0) || !std::isfinite(perUnit))
        throw ModelError(p.sourceFile.empty() ? "fields" : p.sourceFile + ": fields",
                         "a " + what +
                             " field needs a lens that forms an image (this one is "
                             "afocal or its paraxial image plane is at infinity)");
    const int w = model.primaryWavelength();
    const RayAimer aimer(model, AimMode::Real);
    SequentialTraceOptions options;
    options.clipApertures = false;
    // The real chief ray's image height along the azimuth for parameter t.
    auto realHeight = [&](double t, double ux, double uy) -> std::optional<double> {
        const Field f = fieldAt(infinite, t, ux, uy);
        const AimedRay chief = aimer.aim(f.x, f.y, 0.0, 0.0, w);
        if (chief.status != RayStatus::Ok) return std::nullopt;
        const SequentialRayResult r = traceSequential(model, w, chief.ray, options);
        if (!r.ok()) return std::nullopt;
        const Vec3 q = model.localPoint(r.surface, r.ray.origin);
        return q.x * ux + q.y * uy;
    };

    out.system.givenFieldKind = kind;
    out.system.imageHeights = p.system.fields;
    out.system.fieldKind = objectSpace.system.fieldKind;
    for (size_t i = 0; i < out.system.fields.size(); ++i) {
        Field& f = out.system.fields[i];
        const double h = std::hypot(f.x, f.y);
        if (h == 0.0) {
            f.x = f.y = 0.0;
            continue;
        }
        const double ux = f.x / h, uy = f.y / h;
        double t = h / perUnit;  // the paraxial answer
        std::ostringstream name;
        name << (p.sourceFile.empty() ? "" : p.sourceFile + ": ") << "field " << i + 1 << " ("
             << what << " " << h << " mm)";
        if (real) {
            const double tolerance = std::max(1e-9, 1e-9 * h);
            double t0 = t, t1 = t * (1.0 + 1e-3);
            auto g0 = realHeight(t0, ux, uy), g1 = realHeight(t1, ux, uy);
            bool done = false;
            for (int k = 0; k < 60 && g0 && g1; ++k) {
                if (std::abs(*g1 - h) <= tolerance) {
                    done = true;
                    break;
                }
                if (*g1 == *g0) break;
                const double t2 = t1 + (h - *g1) * (t1 - t0) / (*g1 - *g0);
                t0 = t1;
                g0 = g1;
                t1 = t2;
                g1 = realHeight(t1, ux, uy);
            }
            if (!done) {
                const Field paraxial = fieldAt(infinite, t, ux, uy);
                std::ostringstream why;
                why << "no real chief ray reaches this height on the image surface (paraxially it "
                       "needs a field of "
                    << std::hypot(paraxial.x, paraxial.y) << (infinite ? " deg" : " mm")
                    << "; the search from there did not converge)";
                throw ModelError(name.str(), why.str());
            }
            t = t1;
        }
        const Field solved = fieldAt(infinite, t, ux, uy);
        f.x = solved.x;
        f.y = solved.y;
    }
    return out;
}

}  // namespace veil
