#pragma once
// Input files (scene, lens, .zmx, .seq) as the readers see them: from the disk, or from a
// snapshot of their text taken earlier. The Python module's Scene takes one when it is
// created, so its edits and reruns read the texts it holds, not the disk again
// (docs/python.md); the executable takes none and always reads the disk.

#include <filesystem>
#include <map>
#include <optional>
#include <string>

namespace veil {

// The file's bytes: the snapshot's while a FileSnapshotScope holds one for it, else the
// disk's; nullopt when it cannot be opened.
std::optional<std::string> readInputFile(const std::filesystem::path& path);
// Whether readInputFile() would find it.
bool inputFileExists(const std::filesystem::path& path);

// Texts keyed by absolute, lexically normal path (snapshotKey).
using FileSnapshots = std::map<std::string, std::string>;
std::string snapshotKey(const std::filesystem::path& path);

// While alive, readInputFile() serves these texts (one scope at a time, set up before a
// command starts and kept until it ends: the readers only read it).
class FileSnapshotScope {
  public:
    explicit FileSnapshotScope(const FileSnapshots* snapshots);
    ~FileSnapshotScope();
    FileSnapshotScope(const FileSnapshotScope&) = delete;
    FileSnapshotScope& operator=(const FileSnapshotScope&) = delete;

  private:
    const FileSnapshots* previous_;
};

}  // namespace veil
