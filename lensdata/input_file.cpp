#include "lensdata/input_file.h"

#include <fstream>
#include <iterator>

namespace veil {

namespace {

const FileSnapshots*& active() {
    static const FileSnapshots* snapshots = nullptr;
    return snapshots;
}

const std::string* snapshotOf(const std::filesystem::path& path) {
    const FileSnapshots* s = active();
    if (!s) return nullptr;
    const auto it = s->find(snapshotKey(path));
    return it == s->end() ? nullptr : &it->second;
}

}  // namespace

std::string snapshotKey(const std::filesystem::path& path) {
    std::error_code ec;
    const std::filesystem::path absolute = std::filesystem::absolute(path, ec);
    return (ec ? path : absolute).lexically_normal().string();
}

std::optional<std::string> readInputFile(const std::filesystem::path& path) {
    if (const std::string* text = snapshotOf(path)) return *text;
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool inputFileExists(const std::filesystem::path& path) {
    std::error_code ec;
    return snapshotOf(path) != nullptr || std::filesystem::exists(path, ec);
}

FileSnapshotScope::FileSnapshotScope(const FileSnapshots* snapshots) : previous_(active()) {
    active() = snapshots;
}

FileSnapshotScope::~FileSnapshotScope() { active() = previous_; }

}  // namespace veil
