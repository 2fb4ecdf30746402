#pragma once
// Measured scatter: a BSDF tabulated over the specular angle, the radial angle from the
// specular direction and the azimuth about it (lensdata/zemax_bsdf.h has the file format).
//
// The model is the table's interpolant, and every number veil reports comes from it:
//   - within a block (one specular angle), bilinear in (azimuth, radial angle), in degrees;
//     0 beyond the last radial angle and below the surface's horizon; PlaneSymmetrical data
//     mirrored to the other half of the azimuths;
//   - between blocks, linear in the specular angle; before the first block and after the
//     last, that block's table as it stands.
// The scattered fraction (TIS) at a specular angle is the interpolant's integral,
// BSDF cos(s) over the hemisphere, kept in a table at 0.25 degree steps; or, with
// `scaleToFileTis`, each block is first scaled so that its integral at its own angle is the
// TIS its file states (measured tables often stop short of the horizon and miss scatter the
// instrument's integrated value holds).
//
// Directions are drawn exactly from BSDF cos(s) / TIS: a cell of the (azimuth, radial) grid is
// chosen with probability proportional to its largest corner value times its solid angle, a
// direction uniform in solid angle within it, and accepted with probability the interpolant
// times cos(s) over that bound.
//
// Frame: s the specular direction (mirror or refracted), N the normal on the side the light
// leaves by, u the unit vector perpendicular to s toward N (azimuth 0), v = s x u (azimuth 90).

#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace veil {

struct ZemaxBsdf;

class TabulatedLobe {
  public:
    // ModelError naming the file when the table scatters more than all the light at some
    // specular angle, or when scaling to the file's TIS meets a block whose table is empty.
    TabulatedLobe(const ZemaxBsdf& data, bool scaleToFileTis);

    const std::string& source() const { return source_; }
    bool transmission() const { return transmission_; }
    bool scaledToFileTis() const { return scaled_; }
    const std::vector<double>& incidenceDeg() const { return incidenceDeg_; }
    const std::vector<double>& fileTis() const { return fileTis_; }

    // BSDF (1/sr) at specular angle thetaDeg, radial angle r and azimuth phi (radians); 0
    // where cos(s) <= 0.
    double bsdf(double thetaDeg, double r, double phi) const;
    // The scattered fraction at specular angle thetaDeg: from the table, and by a finer
    // quadrature (slow; the table's reference).
    double tis(double thetaDeg) const;
    double tisExact(double thetaDeg) const;
    double maxTis() const { return maxTis_; }
    // (r, phi) with density bsdf cos(s) / tis per steradian; false after too many tries.
    bool sample(double thetaDeg, double u1, double u2, double& r, double& phi) const;

  private:
    struct Block {
        std::vector<double> values;  // [extended azimuth][radial]
        std::vector<double> bound;   // [cell]: largest corner
        std::vector<double> cdf;     // [cell]: cumulative bound x solid angle
        double mass = 0.0;
    };
    struct Blend {
        int k0 = 0, k1 = 0;
        double t = 0.0;  // weight of k1
    };
    Blend blend(double thetaDeg) const;
    int cellOf(double r, double phi, double& fr, double& fp) const;  // -1 outside the table
    double blockValue(const Block& b, int cell, double fr, double fp) const;
    double blockIntegral(const Block& b, double thetaDeg, int order) const;
    void buildBounds(Block& b) const;

    std::string source_;
    bool transmission_ = false, scaled_ = false;
    std::vector<double> incidenceDeg_, fileTis_;
    std::vector<double> azRad_, radRad_;  // extended azimuths (0 to 2 pi), radial angles
    std::vector<double> cellSolidAngle_;
    std::vector<Block> blocks_;
    std::vector<double> tisTable_;  // at 0.25 degree steps, 0 to 90
    double maxTis_ = 0.0;
};

// A BRDF, a BTDF or both from tables. Immutable; shared.
class TabulatedScatter {
  public:
    TabulatedScatter(std::shared_ptr<const TabulatedLobe> brdf,
                     std::shared_ptr<const TabulatedLobe> btdf);
    const TabulatedLobe* reflectLobe() const { return reflect_.get(); }
    const TabulatedLobe* transmitLobe() const { return transmit_.get(); }

  private:
    std::shared_ptr<const TabulatedLobe> reflect_, transmit_;
};
std::ostream& operator<<(std::ostream& os, const TabulatedScatter& s);

}  // namespace veil
