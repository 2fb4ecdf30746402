#pragma once
// First-order (paraxial) data of a sequential system, per wavelength.
//
// Conventions (all lengths mm, signed along z; surface numbers as in the prescription):
//   efl       1/power, positive for a converging system (also through mirrors)
//   bfl       z from the last surface before the image to the paraxial focus
//   ffl       z from surface 1 to the front focal point (negative when in front of it)
//   front principal plane: z from surface 1; rear principal plane: z from the image surface
//   entrance pupil: z from surface 1; exit pupil: z from the image surface
//   working F/#   1 / (2 n' |u'|) of the paraxial marginal ray in image space
//   image-space F/#  efl / entrance pupil diameter (infinite conjugates)
//   paraxial image height: chief ray height at the paraxial image plane, per field
//   Petzval radius: -1 / (n'_k sum (n' - n) c / (n n')), infinite for a flat Petzval field

#include <ostream>
#include <vector>

#include "tracer/sequential/pupil.h"

namespace veil {

class SequentialModel;

struct FirstOrderData {
    double wavelengthNm = 0.0;
    double eflMm = 0.0;
    double bflMm = 0.0;
    double fflMm = 0.0;
    double frontPrincipalPlaneMm = 0.0;
    double rearPrincipalPlaneMm = 0.0;
    double paraxialImageDistanceMm = 0.0;  // z from the image surface to the paraxial focus
    double entrancePupilPositionMm = 0.0;
    double entrancePupilDiameterMm = 0.0;
    double exitPupilPositionMm = 0.0;
    double exitPupilDiameterMm = 0.0;
    double stopSemiDiameterMm = 0.0;
    double workingFNumber = 0.0;
    double imageSpaceFNumber = 0.0;
    double imageSpaceNA = 0.0;
    double objectSpaceNA = 0.0;          // 0 for an object at infinity
    double paraxialMagnification = 0.0;  // 0 for an object at infinity
    double totalTrackMm = 0.0;           // surface 1 to image surface
    double petzvalRadiusMm = 0.0;
    std::vector<double> paraxialImageHeightsMm;  // per system field (y component)
};
std::ostream& operator<<(std::ostream& os, const FirstOrderData& d);

struct FirstOrderReport {
    std::vector<FirstOrderData> wavelengths;  // one per system wavelength
    int primary = 0;
    const FirstOrderData& primaryData() const { return wavelengths[primary]; }
};

FirstOrderData computeFirstOrder(const SequentialModel& model, int w);
FirstOrderReport computeFirstOrder(const SequentialModel& model);

// First-order data of an anamorphic system's x-z section (Prescription::xSection()) at the
// primary wavelength, through the same entrance pupil as the y-z section `y` (computed from
// `model`): an aperture given as an F-number is the y section's, so the x section gets that
// pupil's diameter; an entrance pupil diameter, a numerical aperture or the stop's size apply
// to both sections as given.
FirstOrderData computeXSectionFirstOrder(const SequentialModel& model, const FirstOrderData& y,
                                         const GlassCatalog& catalog);

}  // namespace veil
