#pragma once
// Tabulated BSDF data in the Zemax `.bsdf` text format (the Radiant Imaging "BSDF data
// interchange" format OpticStudio reads for its tabular BSDF scatter): read and written.
//
//   # comment lines (a '#' first on the line)
//   Source  Measured
//   Symmetry  PlaneSymmetrical | Asymmetrical
//   SpectralContent  Monochrome
//   ScatterType  BRDF | BTDF
//   SampleRotation  1        then its values on the next line(s): 0
//   AngleOfIncidence  N      then N angles (degrees, ascending)
//   ScatterAzimuth  N        then N azimuths
//   ScatterRadial  N         then N radial angles
//   Monochrome
//   DataBegin
//   TIS  t                   per angle of incidence: the block's total integrated scatter,
//   ... N_azimuth rows of N_radial BSDF values (1/sr)
//   DataEnd
//
// The coordinates (degrees) are centred on the specular direction: the radial angle is the
// angle between the scattered and the specular direction (0 at specular), the azimuth is
// measured about the specular direction from the side of the surface normal. The "angle of
// incidence" of a block is the angle of the specular direction from the normal: the
// incidence for a BRDF, the refraction angle for a BTDF. PlaneSymmetrical data give the
// azimuths 0 to 180 (the other half mirrors them); Asymmetrical data 0 to 360.
//
// Not read (a ParseError says so): several sample rotations (Asymmetrical4D, anisotropic
// samples whose orientation on the part the scene does not define) and tristimulus data.

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "lensdata/errors.h"

namespace veil {

struct ZemaxBsdfBlock {
    double incidenceDeg = 0.0;
    double fileTis = 0.0;        // the TIS line, as written
    std::vector<double> values;  // [azimuth][radial], 1/sr
    FileLoc loc;                 // the TIS line
};

struct ZemaxBsdf {
    bool planeSymmetric = true;  // PlaneSymmetrical; else Asymmetrical
    bool transmission = false;   // ScatterType BTDF
    std::vector<double> azimuthDeg, radialDeg;
    std::vector<ZemaxBsdfBlock> blocks;  // ascending incidence
    std::vector<std::string> comments;   // header comment lines, without '#'
    std::string source;                  // the file, for messages

    double value(int block, int azimuth, int radial) const {
        return blocks[block].values[azimuth * radialDeg.size() + radial];
    }
};
std::ostream& operator<<(std::ostream& os, const ZemaxBsdf& d);

// Parses the text; ParseError at file:line:col for anything malformed: a missing or
// misordered keyword, a count that does not match its values, angles out of range or not
// ascending, azimuths that do not span 0 to 180 (PlaneSymmetrical) or 0 to 360 (Asymmetrical),
// radial angles that do not start at 0, a block of the wrong size, negative or non-finite
// values, a missing DataEnd.
ZemaxBsdf parseZemaxBsdf(const std::string& text, const std::string& fileName);
// Reads the file (through readInputFile); a ParseError naming it when it cannot be opened.
ZemaxBsdf readZemaxBsdf(const std::filesystem::path& path);

// Writes the format: tab-separated values, no trailing tab, a TIS line per block.
void writeZemaxBsdf(std::ostream& os, const ZemaxBsdf& d);

}  // namespace veil
