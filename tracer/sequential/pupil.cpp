#include "tracer/sequential/pupil.h"

#include <cmath>

#include "lensdata/prescription.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const PupilData& p) {
    return os << "PupilData{stop radius " << p.stopRadiusMm << " mm, EP at z=" << p.entrancePupilZMm
              << " mm, EP radius " << p.entrancePupilRadiusMm << " mm, object z=" << p.objectZMm
              << "}";
}

double effectiveFocalLengthMm(const SequentialModel& model, int w) {
    const int last = model.imageIndex() - 1;
    const ParaxialMatrix m = paraxialMatrix(model, w, 1, last);
    // power = -C; the object-space index is n0, kept as in the reduced form.
    const double power = -m.c;
    return power == 0.0 ? kInfinity : std::abs(model.index(0, w)) / power;
}

PupilData computePupil(const SequentialModel& model, int w) {
    PupilData pd;
    pd.wavelength = w;
    const Prescription& p = model.prescription();
    const int stop = model.stopIndex();
    const double n0 = model.index(0, w);

    // Heights at the stop of two rays started at surface 1: (y=1, nu=0) and (y=0, nu=1).
    double aS = 1.0, bS = 0.0;
    if (stop > 1) {
        const ParaxialRay r1 = traceParaxial(model, w, 1, stop, 1.0, 0.0);
        const ParaxialRay r2 = traceParaxial(model, w, 1, stop, 0.0, 1.0);
        aS = r1.y[stop];
        bS = r2.y[stop];
    }
    // Entrance pupil: the object-space axial point whose rays pass the stop centre:
    // y1 = -zE u0, nu0 = n0 u0  =>  aS (-zE) + bS n0 = 0.
    pd.entrancePupilZMm = aS != 0.0 ? bS * n0 / aS : kInfinity;
    const bool infinite = model.objectAtInfinity();
    const double t0 = model.thicknessMm(0);
    pd.objectZMm = infinite ? -kInfinity : -t0;

    const SystemAperture& ap = p.system.aperture;
    const std::string where =
        p.sourceFile.empty() ? std::string("system aperture") : p.sourceFile + ": system aperture";
    // The marginal ray is (y1, nu0) at surface 1; it sets everything else.
    auto fromEntrancePupilRadius = [&](double epr) {
        if (infinite) {
            pd.marginalY1 = epr;
            pd.marginalNu0 = 0.0;
        } else {
            const double u0 = epr / (pd.entrancePupilZMm - pd.objectZMm);
            pd.marginalNu0 = n0 * u0;
            pd.marginalY1 = u0 * t0;
        }
    };
    switch (ap.kind) {
        case SystemAperture::Kind::EntrancePupilDiameter:
            if (!(ap.value > 0.0)) throw ModelError(where, "entrance pupil diameter must be > 0");
            fromEntrancePupilRadius(0.5 * ap.value);
            break;
        case SystemAperture::Kind::ImageSpaceFNumber: {
            if (!(ap.value > 0.0)) throw ModelError(where, "F-number must be > 0");
            const double efl = effectiveFocalLengthMm(model, w);
            if (!std::isfinite(efl)) throw ModelError(where, "F-number given for an afocal system");
            fromEntrancePupilRadius(0.5 * std::abs(efl) / ap.value);
            break;
        }
        case SystemAperture::Kind::ObjectSpaceNA: {
            if (infinite) throw ModelError(where, "object-space NA needs a finite object distance");
            const double s = ap.value / std::abs(n0);
            if (!(s > 0.0 && s < 1.0)) throw ModelError(where, "object-space NA out of range");
            const double u0 = std::tan(std::asin(s));
            pd.marginalNu0 = n0 * u0;
            pd.marginalY1 = u0 * t0;
            break;
        }
        case SystemAperture::Kind::FloatByStop: {
            const double rs = p.surfaces[stop].clearSemiDiameterMm;
            if (!(rs > 0.0))
                throw ModelError(p.surfaces[stop].name,
                                 "aperture floats by stop size but the stop has no "
                                 "semi-diameter; give the stop its size, or the aperture "
                                 "another way (--set system.aperture.f_number=... or "
                                 "system.aperture.epd_mm=...)");
            if (infinite) {
                if (aS == 0.0)
                    throw ModelError(p.surfaces[stop].name, "no axial ray reaches the stop");
                pd.marginalY1 = rs / aS;
                pd.marginalNu0 = 0.0;
            } else {
                const double denom = aS * t0 + bS * n0;
                if (denom == 0.0)
                    throw ModelError(p.surfaces[stop].name, "no axial ray reaches the stop");
                const double u0 = rs / denom;
                pd.marginalNu0 = n0 * u0;
                pd.marginalY1 = u0 * t0;
            }
            break;
        }
    }
    pd.stopRadiusMm = std::abs(aS * pd.marginalY1 + bS * pd.marginalNu0);
    if (infinite) {
        pd.entrancePupilRadiusMm = std::abs(pd.marginalY1);
    } else {
        const double u0 = pd.marginalNu0 / n0;
        pd.entrancePupilRadiusMm = std::abs(u0 * (pd.entrancePupilZMm - pd.objectZMm));
    }
    if (!(pd.stopRadiusMm > 0.0) || !std::isfinite(pd.stopRadiusMm))
        throw ModelError(p.surfaces[stop].name, "the system aperture gives no light at the stop");
    return pd;
}

}  // namespace veil
