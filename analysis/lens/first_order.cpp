#include "analysis/lens/first_order.h"

#include <cmath>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const FirstOrderData& d) {
    return os << "FirstOrderData{" << d.wavelengthNm << " nm: EFL " << d.eflMm << ", BFL "
              << d.bflMm << ", FFL " << d.fflMm << ", EPD " << d.entrancePupilDiameterMm << ", F/# "
              << d.imageSpaceFNumber << "}";
}

FirstOrderData computeFirstOrder(const SequentialModel& model, int w) {
    FirstOrderData fo;
    fo.wavelengthNm = model.wavelengthNm(w);
    const Prescription& p = model.prescription();
    const int image = model.imageIndex();
    const int last = image - 1;
    const double n0 = model.index(0, w);
    const double nk = model.index(last, w);  // signed image-space index

    // Cardinal points from the system matrix of surfaces 1..last.
    const ParaxialMatrix m = paraxialMatrix(model, w, 1, last);
    const double power = -m.c;
    fo.eflMm = power == 0.0 ? kInfinity : std::abs(n0) / power;
    fo.bflMm = power == 0.0 ? kInfinity : m.a * nk / power;
    fo.fflMm = power == 0.0 ? -kInfinity : -m.d * n0 / power;
    fo.frontPrincipalPlaneMm = fo.fflMm + n0 / power;
    const double zLast = model.surface(last).zMm;
    const double zImage = model.surface(image).zMm;
    const double zFocus = zLast + fo.bflMm;
    fo.rearPrincipalPlaneMm = zFocus - nk / power - zImage;
    fo.totalTrackMm = zImage - model.surface(1).zMm;

    // Pupils and the marginal ray at this wavelength.
    const PupilData pupil = computePupil(model, w);
    fo.entrancePupilPositionMm = pupil.entrancePupilZMm - model.surface(1).zMm;
    fo.entrancePupilDiameterMm = 2.0 * pupil.entrancePupilRadiusMm;
    fo.stopSemiDiameterMm = pupil.stopRadiusMm;
    const ParaxialRay marginal =
        traceParaxial(model, w, 1, last, pupil.marginalY1, pupil.marginalNu0);
    const double uk = marginal.nu[last] / nk;  // image-space marginal slope dy/dz
    // The marginal ray crosses the axis at the paraxial image (for finite objects too).
    const double zImageParaxial = uk != 0.0 ? zLast - marginal.y[last] / uk : kInfinity;
    fo.paraxialImageDistanceMm = zImageParaxial - zImage;
    if (model.objectAtInfinity()) {
        // The image of an infinite object sits at the back focus.
        fo.paraxialImageDistanceMm = zFocus - zImage;
    }
    const double sinU = std::sin(std::atan(std::abs(uk)));
    fo.imageSpaceNA = std::abs(nk) * sinU;
    fo.workingFNumber = uk != 0.0 ? 1.0 / (2.0 * std::abs(nk) * std::abs(uk)) : kInfinity;
    fo.imageSpaceFNumber = std::abs(fo.eflMm) / fo.entrancePupilDiameterMm;
    if (!model.objectAtInfinity()) {
        const double u0 = pupil.marginalNu0 / n0;
        fo.objectSpaceNA = std::abs(n0) * std::sin(std::atan(std::abs(u0)));
        // Paraxial magnification from a chief-type ray: m = (n u)_object / (n u)_image.
        fo.paraxialMagnification = uk != 0.0 ? (pupil.marginalNu0) / (marginal.nu[last]) : 0.0;
    }

    // Exit pupil: the image of the stop centre in image space.
    const int stop = model.stopIndex();
    {
        const ParaxialRay c = traceParaxial(model, w, stop, last, 0.0, 1.0);
        const double ucz = c.nu[last] / nk;
        if (ucz != 0.0) {
            const double zXP = zLast - c.y[last] / ucz;
            fo.exitPupilPositionMm = zXP - zImage;
            fo.exitPupilDiameterMm = 2.0 * std::abs(marginal.y[last] + (zXP - zLast) * uk);
        } else {
            fo.exitPupilPositionMm = kInfinity;
            fo.exitPupilDiameterMm = kInfinity;
        }
    }

    // Paraxial chief rays per field: through the entrance pupil centre.
    for (const Field& f : p.system.fields) {
        double y1 = 0.0, nu0 = 0.0;
        const bool angle = p.system.fieldKind == SystemData::FieldKind::AngleDeg;
        const double zE = pupil.entrancePupilZMm;
        if (angle) {
            const double u0 = std::tan(f.y * M_PI / 180.0);
            nu0 = n0 * u0;
            y1 = std::isfinite(zE) ? -zE * u0 : 0.0;
        } else {
            const double t0 = model.thicknessMm(0);
            const double u0 = -f.y / (zE + t0);  // from (y, -t0) to (0, zE)
            nu0 = n0 * u0;
            y1 = f.y + u0 * t0;
        }
        const ParaxialRay chief = traceParaxial(model, w, 1, last, y1, nu0);
        const double ucz = chief.nu[last] / nk;
        const double zPlane = model.objectAtInfinity() ? zFocus : zImageParaxial;
        fo.paraxialImageHeightsMm.push_back(chief.y[last] + (zPlane - zLast) * ucz);
    }

    // Petzval sum over the surfaces that refract or reflect.
    double petzval = 0.0;
    for (int i = 1; i <= last; ++i) {
        const double n = model.index(i - 1, w), np = model.index(i, w);
        petzval += (np - n) * paraxialCurvature(p.surfaces[i]) / (n * np);
    }
    fo.petzvalRadiusMm = petzval == 0.0 ? kInfinity : -1.0 / (nk * petzval);
    return fo;
}

FirstOrderReport computeFirstOrder(const SequentialModel& model) {
    FirstOrderReport r;
    r.primary = model.primaryWavelength();
    for (int w = 0; w < model.wavelengthCount(); ++w)
        r.wavelengths.push_back(computeFirstOrder(model, w));
    return r;
}

FirstOrderData computeXSectionFirstOrder(const SequentialModel& model, const FirstOrderData& y,
                                         const GlassCatalog& catalog) {
    Prescription x = model.prescription().xSection();
    if (x.system.aperture.kind == SystemAperture::Kind::ImageSpaceFNumber)
        x.system.aperture = {SystemAperture::Kind::EntrancePupilDiameter,
                             y.entrancePupilDiameterMm};
    const SequentialModel m = SequentialModel::build(x, catalog);
    return computeFirstOrder(m, m.primaryWavelength());
}

}  // namespace veil
