#pragma once
// Output files written whole or not at all: every writer writes "<path>.tmp" and renames it
// over the path, so a failed write never leaves a half-written file under the real name.

#include <filesystem>
#include <string>
#include <string_view>

namespace veil {

// "<path>.tmp".
std::filesystem::path temporaryFor(const std::filesystem::path& path);
// Removes a file, ignoring errors (a temporary that may not exist).
void removeQuietly(const std::filesystem::path& path);
// Renames tmp over path; on failure removes tmp and throws std::runtime_error naming path.
void commitFile(const std::filesystem::path& tmp, const std::filesystem::path& path);
// Why the last failed system call failed ("No space left on device"), for a write error's
// message; "the write failed" when the system gave no reason (errno 0). Clear errno before
// the calls it explains.
std::string systemReason();
// Writes text to path through its temporary. std::runtime_error naming path on failure.
void writeTextFile(const std::filesystem::path& path, std::string_view text);

}  // namespace veil
