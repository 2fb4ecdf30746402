#pragma once
// The conventions every subcommand follows (docs/cli.md), in one place so that a new command
// is born with them and tests/cli/conventions_test.cpp can hold every command to them:
//
//   -n, --rays N    emitted rays per source; N is a whole number written 20000, 2e4, 20k or
//                   2M (k = 1e3, M = 1e6, G = 1e9); 1.5 or 0.5k is an error, not 1 ray
//   --threads N     worker threads (0: all cores)        } every command that traces
//   --seed N        random seed                          }
//   --field X,Y     collimated 1 W beam per field, replacing the scene's sources (repeatable)
//   -o, --output    a folder for commands that write several files (created as needed, by
//                   default named after the command), a file for those that write one
//   --json          the report as JSON on standard output instead of text; files are then
//                   written only when -o is given
//   --quiet         no progress and no closing list of files (warnings and errors remain)
//
// Every run ends by listing what it wrote (WrittenFiles), in text or under "files" in JSON.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace veil {
class Picture;
struct PreviewScale;
struct TransportOptions;
}

namespace veil::cli {

// "20000", "2e4", "20k", "2M" -> the count; nullopt with *error set for anything else
// (fractions, negatives, words, more than 1e13).
std::optional<uint64_t> parseCount(const std::string& text, std::string* error);

// -n/--rays bound to `rays`, checked by parseCount and at least `min`.
CLI::Option* addRays(CLI::App* sub, uint64_t& rays, const std::string& help, uint64_t min = 1);
// A count option of another name (--batch, ...), written like --rays.
CLI::Option* addCount(CLI::App* sub, const std::string& name, uint64_t& value,
                      const std::string& help, uint64_t min = 1);
// --max-memory: the most memory the run (`what`: "render", "trace") may take, in bytes, 4G
// meaning 4e9; 0 (the default): the machine's. The run's estimate is checked before any work.
CLI::Option* addMaxMemory(CLI::App* sub, uint64_t& bytes, const std::string& what);
// --threads and --seed.
void addRunControls(CLI::App* sub, int& threads, uint64_t& seed);
// -o/--output as a folder (default shown: ./<defaultName>) or as one file.
CLI::Option* addOutputFolder(CLI::App* sub, std::string& folder, const std::string& defaultName);
CLI::Option* addOutputFile(CLI::App* sub, std::string& file, const std::string& what);
// The forward tracer's knobs, shared by trace and sweep: --mode, --min-flux,
// --max-split-depth, --roulette, --max-segments (defaults: TransportOptions's).
struct TransportFlags {
    std::string mode = "split";
    double minRelativeFlux = 1e-4;
    double rescueRelativeFlux = 1e-2;  // Russian roulette below minRelativeFlux, kept at this
    bool minFluxCut = false;           // cut below minRelativeFlux instead (biased)
    int maxSplitDepth = 64;
    double roulette = 0.0;
    int maxSegments = 1000;
};
void addTransportFlags(CLI::App* sub, TransportFlags& flags);
// Into the transport's options; the seed and the rest are left as they are.
// Split mode without a flux floor (--min-flux 0) and without roulette is refused unless
// --max-split-depth is at most this (2^20 branches per ray): ModelError naming --min-flux.
inline constexpr int kMaxUnculledSplitDepth = 20;
void applyTransportFlags(const TransportFlags& flags, TransportOptions& options);
// --decades D and --range LO:HI: the PNG previews' colour scale (PreviewScale: chosen from
// the light without them).
struct PreviewFlags {
    double decades = 0.0;
    std::string range;  // "LO:HI" in the preview's unit, or empty
};
void addPreviewFlags(CLI::App* sub, PreviewFlags& flags);
// "LO:HI" with 0 < LO < HI, both finite, into (LO, HI); nullopt with *error set otherwise.
std::optional<std::pair<double, double>> parseRange(const std::string& text, std::string* error);
// The flags as a PreviewScale (a malformed --range is a ParseError naming it).
PreviewScale previewScale(const PreviewFlags& flags);
// --json and --quiet.
void addReportFlags(CLI::App* sub, bool& json, bool& quiet);
// --field X,Y (repeatable).
CLI::Option* addFields(CLI::App* sub, std::vector<std::string>& fields);
// The --field values as (x, y); a malformed one is a ParseError naming it.
std::vector<std::pair<double, double>> parseFields(const std::vector<std::string>& fields);


// Throws ParseError naming `option` unless `folder` (or the nearest existing folder above it)
// is a folder veil may create files in.
// `shown`: the path to name in the message (default: the folder).
void requireWritableFolder(const std::filesystem::path& folder, const std::string& option,
                           const std::string& shown = "");

// Where a command writes its files: the -o folder given, else the default folder, else
// (with --json and no -o) nowhere: empty. Checked before any work: the folder, or the
// nearest folder above it that exists, must be a folder veil may write into (a file, a
// read-only folder, /proc or an empty -o is a ParseError naming -o), so a run never fails
// only after it has traced. Nothing is created here.
std::filesystem::path outputFolder(const std::string& given, const std::string& defaultName,
                                   bool json);

inline constexpr const char* kVeilVersion = "0.1.0";

// The command line as given (main() records it; the run manifest quotes it).
void setCommandLine(int argc, char** argv);

// The manifest of a finished run, written last into its output folder (kRunManifest below).
inline constexpr const char* kRunManifest = "veil-run.json";
// The lock of a folder a run is writing into (WrittenFiles::beginRun).
inline constexpr const char* kRunLock = ".veil-lock";

// The files a run wrote, in order, for its closing list, and the run manifest of its output
// folder (docs/cli.md, "Output folders"). A folder holds at most one finished run:
//   beginRun(folder)  before the run writes its first file there: removes the manifest of an
//                     older run first, then each file it lists that is unchanged (the size and
//                     CRC-32 it lists; a changed file is kept and named on stderr), then
//                     temporaries a killed run left (NAME.EXT.tmp, NAME.EXT.partial of veil's
//                     file types) in the folder and its subfolders;
//                     (keepFiles: only the manifest and the temporaries go);
//   finishRun()       after the last file: writes veil-run.json with the run's id, command
//                     line, veil version, time and every file's name, size and CRC-32.
// From beginRun to finishRun (or the end of the run, however it ends) the folder is locked
// (kRunLock: the process id, host and command line): a second run that begins writing there
// meanwhile is refused with a message naming the first. A lock whose process is gone (a run
// killed on this host) is removed, with a note.
// A folder without veil-run.json holds no finished run (one is writing, failed or was
// killed); one with it holds exactly the files it lists, as they were written.
class WrittenFiles {
  public:
    WrittenFiles() = default;
    WrittenFiles(const WrittenFiles&) = delete;
    WrittenFiles& operator=(const WrittenFiles&) = delete;
    WrittenFiles(WrittenFiles&& o) noexcept;
    WrittenFiles& operator=(WrittenFiles&& o) noexcept;
    ~WrittenFiles();
    void add(const std::filesystem::path& file) { files_.push_back(file); }
    const std::vector<std::filesystem::path>& files() const { return files_; }
    // "wrote 3 files in out/sun7: sensor.exr, sensor.png, summary.json" (paths relative to
    // the folder they share, if any).
    void print(std::ostream& os) const;
    nlohmann::json json() const;
    // No-ops for an empty folder (a --json run without -o writes nothing).
    // keepFiles (a resumable command: render --resume, sweep): the older run's files stay
    // to be continued or overwritten; its manifest and temporaries go, except `keep` (the
    // partial ray database a resumed trace goes on writing).
    void beginRun(const std::filesystem::path& folder, bool keepFiles = false,
                  const std::vector<std::filesystem::path>& keep = {});
    void finishRun();

  private:
    void unlock();
    std::vector<std::filesystem::path> files_;
    std::filesystem::path folder_;
    std::filesystem::path lock_;  // held while not empty
};

// A study's closing report on standard output: with --json its JSON object (jsonText) with
// the written files under "files"; else, unless --quiet, the text and the list of files.
void printReport(const std::string& jsonText, const std::string& text,
                 const WrittenFiles& written, bool json, bool quiet);

// A picture as `stem`.svg and `stem`.png (widthPx wide), both listed in `written`.
void writePicture(const Picture& picture, const std::filesystem::path& stem, int widthPx,
                  WrittenFiles& written);

}  // namespace veil::cli
