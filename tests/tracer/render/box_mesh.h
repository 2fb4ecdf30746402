#pragma once
// Pieces of the renderer's test scenes: a closed box mesh written as an OFF file, and the
// system of a biconvex singlet.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "geometry/vec.h"

namespace veil {

// A closed box mesh (OFF), outward faces.
inline void writeBox(const std::string& path, Vec3 lo, Vec3 hi) {
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fprintf(f, "OFF\n8 12 0\n");
    for (int c = 0; c < 8; ++c)
        fprintf(f, "%.17g %.17g %.17g\n", c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y,
                c & 4 ? hi.z : lo.z);
    // Corner c: bit 0 x, bit 1 y, bit 2 z. Two triangles per face, counter-clockwise seen
    // from outside.
    const int tris[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                             {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    for (const auto& t : tris) fprintf(f, "3 %d %d %d\n", t[0], t[1], t[2]);
    fclose(f);
}

// The head of a scene's [system] table: one wavelength (550 nm), a biconvex singlet (n 1.5,
// radii 100 mm, 5 mm thick, clear radius 12.5 mm, the stop at its front face) and the gap
// `gapMm` behind it. The surfaces array is left open for more rows and its closing "]".
inline std::string singletSystem(double gapMm) {
    return "[system]\nwavelengths_nm = [550.0]\naperture = { epd_mm = 20.0 }\n"
           "fields_deg = [0.0]\nsurfaces = [\n"
           "  { r = 100.0, t = 5.0, glass = { nd = 1.5, vd = 0.0 }, sd = 12.5, stop = true },\n"
           "  { r = -100.0, t = " +
           std::to_string(gapMm) + ", sd = 12.5 },\n";
}

}  // namespace veil
