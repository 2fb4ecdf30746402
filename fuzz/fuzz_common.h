#pragma once

// Shared by the libFuzzer targets in this folder (fuzz/README.md).
//
// A target feeds one input to one of veil's readers. A clean rejection is what a user gets
// for bad input: a ParseError (file:line:col), a ModelError (the object) or, for the ray
// database, a RayDatabaseError (caught by that target). Anything else escaping the reader
// (std::out_of_range from a library call, a logic_error, a bad_alloc from an unchecked size) ends
// the process: libFuzzer reports it as a crash, as it does a sanitizer finding.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "lensdata/errors.h"

namespace veil::fuzz {

template <class F>
void expectCleanRejection(F&& read) {
    try {
        read();
    } catch (const ParseError&) {
    } catch (const ModelError&) {
    }
}

inline std::string_view asText(const uint8_t* data, size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

// A folder of this process's own (readers that take a path read their input from there).
inline const std::filesystem::path& scratchFolder() {
    static const std::filesystem::path folder = [] {
        const char* tmp = std::getenv("TMPDIR");
        std::filesystem::path f = std::filesystem::path(tmp && *tmp ? tmp : "/tmp") /
                                  ("veil_fuzz_" + std::to_string(::getpid()));
        std::filesystem::create_directories(f);
        return f;
    }();
    return folder;
}

// scratchFolder()/scenes, beside copies of examples/lenses and examples/zmx, so that a scene
// written there finds `lens = "../lenses/..."` as the examples do.
inline const std::filesystem::path& sceneFolder() {
    static const std::filesystem::path folder = [] {
        const auto root = scratchFolder();
        for (const char* sub : {"lenses", "zmx"}) {
            std::filesystem::create_directories(root / sub);
            std::filesystem::copy(std::filesystem::path(VEIL_SOURCE_DIR) / "examples" / sub,
                                  root / sub,
                                  std::filesystem::copy_options::overwrite_existing |
                                      std::filesystem::copy_options::recursive);
        }
        std::filesystem::create_directories(root / "scenes");
        return root / "scenes";
    }();
    return folder;
}

inline std::filesystem::path writeScratch(const std::string& name, std::string_view bytes) {
    const std::filesystem::path p = scratchFolder() / name;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary | std::ios::trunc)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p;
}

}  // namespace veil::fuzz
