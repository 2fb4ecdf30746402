#include "lensdata/output_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>

namespace veil {

std::filesystem::path temporaryFor(const std::filesystem::path& path) {
    std::filesystem::path tmp = path;
    tmp += ".tmp";
    return tmp;
}

std::string systemReason() {
    const int e = errno;
    return e != 0 ? std::strerror(e) : "the write failed";
}

void removeQuietly(const std::filesystem::path& path) {
    std::error_code ec;
    std::filesystem::remove(path, ec);
}

void commitFile(const std::filesystem::path& tmp, const std::filesystem::path& path) {
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        removeQuietly(tmp);
        throw std::runtime_error("cannot write " + path.string() + ": " + ec.message());
    }
}

void writeTextFile(const std::filesystem::path& path, std::string_view text) {
    const std::filesystem::path tmp = temporaryFor(path);
    {
        errno = 0;
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
        out.close();
        if (!out) {
            const std::string reason = systemReason();
            removeQuietly(tmp);
            throw std::runtime_error("cannot write " + path.string() + ": " + reason);
        }
    }
    commitFile(tmp, path);
}

}  // namespace veil
