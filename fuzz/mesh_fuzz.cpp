// libFuzzer target: a mesh file (geometry/mesh_io.h). The first byte picks the format (.stl,
// .obj, .ply, .off), the rest is the file.
#include "fuzz/fuzz_common.h"
#include "geometry/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    static const char* const kinds[] = {"stl", "obj", "ply", "off"};
    const auto path = veil::fuzz::writeScratch(std::string("input.") + kinds[data[0] % 4],
                                               veil::fuzz::asText(data + 1, size - 1));
    veil::fuzz::expectCleanRejection([&] {
        veil::MeshReadReport report;
        veil::readMeshFile(path, &report);
    });
    return 0;
}
