#pragma once
// Paraxial (first-order) ray trace in the y-nu form.
//
// At surface i with curvature c and gap indices n (before) and n' (after, signed):
//   refraction  n'u' = n u - y c (n' - n)
//   transfer    y_{i+1} = y_i + t_i u'_i,   u'_i = (n'u')_i / n'_i
// Mirrors need nothing special: n' = -n. Only the base curvature and the r^2 term of an
// even asphere (which adds 2 a2 to the curvature) act paraxially.

#include <ostream>
#include <vector>

#include "tracer/sequential/sequential_model.h"

namespace veil {

// A paraxial ray: height y (mm) at each surface and the reduced angle n u in the gap after it.
struct ParaxialRay {
    std::vector<double> y;   // [surface]
    std::vector<double> nu;  // [gap] (after refraction at that surface)
    int first = 0;           // surface where the ray was started
    int last = 0;            // surface where it was stopped
};
std::ostream& operator<<(std::ostream& os, const ParaxialRay& r);

// The paraxial curvature of a surface: c + 2 a2, plus twice the r^2 term of a Qbfs departure.
double paraxialCurvature(const Surface& s);

// Traces from surface `first` (height y, reduced angle nuBefore in the gap before it) to
// surface `last` inclusive (refracting at `last` too).
ParaxialRay traceParaxial(const SequentialModel& model, int w, int first, int last, double y,
                          double nuBefore);

// The 2x2 reduced-angle transfer matrix [y', n'u'] = M [y, nu] from just before surface
// `first` to just after surface `last`, refraction included at both ends.
struct ParaxialMatrix {
    double a = 1, b = 0, c = 0, d = 1;
};
std::ostream& operator<<(std::ostream& os, const ParaxialMatrix& m);
ParaxialMatrix paraxialMatrix(const SequentialModel& model, int w, int first, int last);

}  // namespace veil
