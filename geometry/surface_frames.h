#pragma once
// Where every surface of a prescription sits, its local frame (vertex at the origin, z the
// local optical axis) in global coordinates, and what it is: its exact shape in that frame.
//
// The global frame is the coordinate system light arrives in at surface 1: surface 1's
// vertex at the origin, z the object-space axis. The object surface sits one object distance
// in front (at -infinity for an object at infinity). Each thickness runs along its surface's
// own z axis to the next vertex (negative after an odd number of mirrors: frames do not
// flip at mirrors, as in lens design programs), and a coordinate break turns and shifts the
// frame of itself and of every surface after it (CoordinateBreak in lensdata/prescription.h).
// Without breaks every frame is the global one moved along z, vertex k at the sum of the
// thicknesses before it, exactly as the sums come out.

#include <vector>

#include "geometry/frame.h"
#include "geometry/surface_shape.h"
#include "lensdata/prescription.h"

namespace veil {

// Every entry of the two rotations within tol (the same axes, to rounding).
bool sameRotation(const glm::dmat3& a, const glm::dmat3& b, double tol = 1e-12);

// The frame a coordinate break makes of the incoming one.
Frame breakFrame(const Frame& incoming, const CoordinateBreak& b);

// One frame per surface. A frame that comes back to the global axis within rounding (breaks
// that cancel) is snapped onto it, so it tests onAxis().
std::vector<Frame> surfaceFrames(const Prescription& p);

// The frame is the global one moved along z: no rotation, the vertex on the z axis.
bool onAxis(const Frame& f);

// The first surface light meets (coordinate breaks left out, the object too) whose frame is
// not onAxis(), or -1 when the system is coaxial.
int firstSurfaceOffAxis(const Prescription& p, const std::vector<Frame>& frames);

// The exact shape of a surface: its conic, even and odd asphere terms, and a Q-type
// departure turned into even asphere terms (Qcon) or terms over w (Qbfs), geometry/qtype.h.
SurfaceShape surfaceShape(const Surface& s);

}  // namespace veil
