#pragma once
// A property's scatter written out as a table: the BSDF of one channel (reflection or
// transmission) at the grid of a Zemax .bsdf file (lensdata/zemax_bsdf.h), in the
// coordinates tracer/surfaces/tabulated_bsdf.h reads back, with each block's TIS the channel's
// scattered fraction at that angle. For exporting analytic models to other programs and for
// checking the tabulated model against the analytic one it came from.

#include <vector>

#include "lensdata/zemax_bsdf.h"
#include "tracer/surfaces/optical_property.h"

namespace veil {

struct TabulationGrid {
    std::vector<double> incidenceDeg;  // specular angles, ascending, in [0, 90)
    std::vector<double> azimuthDeg;    // 0 to 180 (planeSymmetric) or 0 to 360
    std::vector<double> radialDeg;     // from 0, ascending, <= 180
    bool planeSymmetric = true;
};
std::ostream& operator<<(std::ostream& os, const TabulationGrid& g);

// Light from index n1 onto a surface with normal +z (n2 across it), arriving in the x-z
// plane at incidenceDeg and leaning toward +x: the frame tabulateScatter() writes tables in,
// and the one veil scatter plots in.
SurfaceContext incidenceContext(double incidenceDeg, double wavelengthNm, double n1 = 1.0,
                                double n2 = 1.0, bool opaque = false);

// The grid `veil scatter --bsdf` writes: blocks every 10 degrees to 80, then 85 and 89;
// azimuths every 10 degrees (plane-symmetric); radial angles every 0.25 degree to 5, every
// degree to 30, every 5 degrees to 180.
TabulationGrid exportGrid();

// The light arrives from index n1 (n2 across the surface) at vacuum wavelength wavelengthNm.
// For transmission the grid's incidence angles are refraction angles (the specular direction
// of a BTDF); angles the light cannot refract to are left out of the table. Throws
// std::invalid_argument for an empty channel or a grid the format cannot hold.
ZemaxBsdf tabulateScatter(const OpticalProperty& property, bool transmit,
                          const TabulationGrid& grid, double wavelengthNm, double n1 = 1.0,
                          double n2 = 1.0);

}  // namespace veil
