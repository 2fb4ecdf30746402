// libFuzzer target: a mesh file (geometry/mesh_io.h), as a user's file: the format is the one
// its content says, as its name's extension would (PLY and OFF by their header line, STL by
// "solid" or by the binary layout's size, 84 + 50 n bytes, OBJ otherwise), so every seed and
// regression input is a mesh file veil reads as it is.
#include <cctype>
#include <cstring>
#include <string>

#include "fuzz/fuzz_common.h"
#include "geometry/mesh_io.h"

namespace {

const char* formatOf(const uint8_t* data, size_t size) {
    size_t i = 0;
    while (i < size && std::strchr(" \t\r\n", static_cast<char>(data[i])) && data[i] != 0) ++i;
    size_t end = i;
    while (end < size && !std::strchr(" \t\r\n", static_cast<char>(data[end]))) ++end;
    const std::string first(reinterpret_cast<const char*>(data + i), end - i);
    auto lower = [](std::string s) {
        for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        return s;
    };
    if (lower(first) == "ply") return "ply";
    if (first.find("OFF") != std::string::npos) return "off";  // OFF, COFF, NOFF, OFF10 ...
    if (lower(first).rfind("solid", 0) == 0) return "stl";
    if (size >= 84) {
        uint32_t triangles = 0;
        std::memcpy(&triangles, data + 80, sizeof triangles);  // little endian, as STL is
        if (size == 84 + 50 * static_cast<uint64_t>(triangles)) return "stl";
    }
    return "obj";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const auto path = veil::fuzz::writeScratch(std::string("input.") + formatOf(data, size),
                                               veil::fuzz::asText(data, size));
    veil::fuzz::expectCleanRejection([&] {
        veil::MeshReadReport report;
        veil::readMeshFile(path, &report);
    });
    return 0;
}
