#pragma once
// Rays from a field point through a pupil point.
//
// Pupil coordinates (px, py) lie in the unit disk. With paraxial aiming they scale the
// paraxial entrance pupil; with real aiming the ray is solved (Newton, finite-difference
// Jacobian) to cross the real stop at (px, py) times the stop radius, which keeps the chief
// ray through the stop centre when the pupil is aberrated or displaced off axis.

#include <optional>
#include <ostream>

#include "geometry/vec.h"
#include "tracer/sequential/pupil.h"
#include "tracer/sequential/ray_status.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

enum class AimMode { Paraxial, Real };
std::ostream& operator<<(std::ostream& os, AimMode m);

struct AimedRay {
    RayStatus status = RayStatus::Ok;  // Invalid if real aiming did not converge
    Ray ray;                           // in object space, global frame
    int iterations = 0;
};

class RayAimer {
  public:
    RayAimer(const SequentialModel& model, AimMode mode = AimMode::Real);
    RayAimer(const SequentialModel& model, const PupilData& pupil, AimMode mode);

    const PupilData& pupil() const { return pupil_; }
    AimMode mode() const { return mode_; }

    // A ray from field (fx, fy) (degrees or object mm per the system's field kind) through
    // pupil point (px, py) at wavelength w.
    AimedRay aim(double fx, double fy, double px, double py, int w) const;
    AimedRay aim(const Field& f, double px, double py, int w) const {
        return aim(f.x, f.y, px, py, w);
    }

  private:
    // The object-space ray through entrance-pupil-plane point (ex, ey).
    Ray rayThrough(double fx, double fy, double ex, double ey) const;

    const SequentialModel* model_;
    PupilData pupil_;
    AimMode mode_;
    bool angleField_;
};

}  // namespace veil
