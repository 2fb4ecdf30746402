#pragma once
// A closed box mesh written as an OFF file, for the renderer's test scenes.

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

}  // namespace veil
