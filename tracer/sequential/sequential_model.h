#pragma once
// A prescription resolved for tracing: exact surface shapes placed on the axis and signed
// refractive indices per gap and wavelength.
//
//   gap i: from surface i to surface i+1; index(i, w) = n of that gap at wavelength w.
//
// Frames: the global frame is the coordinate system light arrives in at surface 1 (its
// vertex at the origin, z the optical axis of object space). Each surface has a frame: its
// vertex and axes in global coordinates. Without coordinate breaks (Surface::coordinateBreak)
// every frame is the global one moved along z, each vertex at z += thicknessMm (negative after
// an odd number of mirrors); a break turns and shifts the frame of itself and every surface
// after it, and a thickness runs along its surface's own z axis. Indices are signed as in lens
// design programs: negative in gaps where light travels toward -z of the local axis, so the
// paraxial equations n'u' = nu - y c (n' - n) hold through mirrors unchanged. The real-ray
// trace uses |n|. Paraxial (first-order) data ignore coordinate breaks, as lens design
// programs do: zMm is the position along the unfolded axis, and it is the global z only in a
// coaxial system (coaxial()).

#include <ostream>
#include <string>
#include <vector>

#include "geometry/frame.h"
#include "geometry/surface_shape.h"
#include "lensdata/prescription.h"

namespace veil {

class GlassCatalog;

struct SequentialSurface {
    std::string name;
    SurfaceShape shape;
    // Vertex position along the unfolded axis: the sum of the thicknesses before it from
    // surface 1; the global z of the vertex when the model is coaxial.
    double zMm = 0.0;
    Frame frame;                   // the surface's local frame in global coordinates
    bool rotated = false;          // the frame turns the axes (else it only shifts them)
    bool coordinateBreak = false;  // a break: not intersected by sequential rays
    // Global to local and back: a shift alone unless the frame turns the axes (the common,
    // coaxial case costs no rotation).
    Ray toLocal(const Vec3& p, const Vec3& d) const {
        return rotated ? frame.toLocal({p, d}) : Ray{p - frame.translation, d};
    }
    Vec3 toGlobalPoint(const Vec3& q) const {
        return rotated ? frame.toGlobalPoint(q) : q + frame.translation;
    }
    Vec3 toGlobalDirection(const Vec3& v) const { return rotated ? frame.toGlobalDirection(v) : v; }
    double clearSemiDiameterMm = 0.0;  // 0 = not given
    // Rays outside clearSemiDiameterMm are vignetted. False for the stop (the system aperture
    // sets its size) and for semi-diameters a lens file marked as computed.
    bool vignettes = false;
    // Central hole or obscuration (Surface::innerSemiDiameterMm), 0 = none. Rays inside it are
    // Clipped on every surface, vignetting or not: a hole is always given, never computed.
    double innerSemiDiameterMm = 0.0;
    bool mirror = false;
    bool stop = false;
};
std::ostream& operator<<(std::ostream& os, const SequentialSurface& s);

class SequentialModel {
  public:
    // Resolves every material with `catalog` (the prescription's preferred catalogs first).
    // Throws ModelError naming the surface for an unknown glass or an index that is not
    // defined at one of the system wavelengths.
    static SequentialModel build(const Prescription& prescription, const GlassCatalog& catalog);
    // Same, at the given wavelengths (nm) instead of the system's.
    static SequentialModel build(const Prescription& prescription, const GlassCatalog& catalog,
                                 const std::vector<double>& wavelengthsNm);

    const Prescription& prescription() const { return prescription_; }
    const std::vector<SequentialSurface>& surfaces() const { return surfaces_; }
    const SequentialSurface& surface(int i) const { return surfaces_[i]; }
    int surfaceCount() const { return static_cast<int>(surfaces_.size()); }
    int stopIndex() const { return stopIndex_; }
    int imageIndex() const { return surfaceCount() - 1; }
    // Every surface frame is the global one moved along z: no coordinate break tilts or
    // decenters anything (breaks that cancel count as none).
    bool coaxial() const { return coaxial_; }
    // A global point in surface i's frame.
    Vec3 localPoint(int i, const Vec3& global) const {
        return surfaces_[i].frame.toLocalPoint(global);
    }

    int wavelengthCount() const { return static_cast<int>(wavelengthsNm_.size()); }
    double wavelengthNm(int w) const { return wavelengthsNm_[w]; }
    int primaryWavelength() const { return primaryWavelength_; }

    // Signed index of gap `gap` at wavelength `w` (see the header comment).
    double index(int gap, int w) const { return indices_[w][gap]; }
    // +1 where light travels toward +z in the gap, -1 toward -z.
    double direction(int gap) const { return directions_[gap]; }
    // Signed thickness of gap `gap` (mm); infinite for an object at infinity.
    double thicknessMm(int gap) const;
    bool objectAtInfinity() const;

  private:
    Prescription prescription_;
    std::vector<SequentialSurface> surfaces_;
    std::vector<double> wavelengthsNm_;
    int primaryWavelength_ = 0;
    int stopIndex_ = 1;
    std::vector<std::vector<double>> indices_;  // [wavelength][gap]
    std::vector<double> directions_;            // [gap]
    bool coaxial_ = true;
};

}  // namespace veil
