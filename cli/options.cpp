#include "cli/options.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <random>
#include <sstream>

#include "analysis/pictures/picture.h"
#include "analysis/reports/image_output.h"
#include "cli/app.h"
#include "lensdata/errors.h"
#include "lensdata/output_file.h"
#include "tracer/records/ray_database.h"
#include "tracer/transport/nonsequential.h"

namespace veil::cli {

namespace {

constexpr double kMaxCount = 1e13;

CLI::Validator countValidator(uint64_t min) {
    // A transform: the text is rewritten to the plain integer CLI11 then converts.
    return CLI::Validator(
        [min](std::string& text) -> std::string {
            std::string error;
            const std::optional<uint64_t> n = parseCount(text, &error);
            if (!n) return error;
            if (*n < min)
                return "'" + text + "' is less than " + std::to_string(min);
            text = std::to_string(*n);
            return {};
        },
        "N (20000, 2e4, 20k, 2M)", "count");
}

}  // namespace

std::optional<uint64_t> parseCount(const std::string& text, std::string* error) {
    auto fail = [&](const std::string& why) -> std::optional<uint64_t> {
        if (error) *error = "'" + text + "' " + why;
        return std::nullopt;
    };
    if (text.empty()) return fail("is not a number");
    std::string digits = text;
    double scale = 1.0;
    switch (digits.back()) {
        case 'k':
        case 'K':
            scale = 1e3;
            break;
        case 'M':
            scale = 1e6;
            break;
        case 'G':
            scale = 1e9;
            break;
        default:
            break;
    }
    if (scale != 1.0) digits.pop_back();
    if (digits.empty() || digits.find_first_not_of("0123456789.eE+") != std::string::npos)
        return fail("is not a whole number (write 20000, 2e4, 20k or 2M)");
    char* end = nullptr;
    const double mantissa = std::strtod(digits.c_str(), &end);
    if (end != digits.c_str() + digits.size() || !std::isfinite(mantissa))
        return fail("is not a number (write 20000, 2e4, 20k or 2M)");
    const double value = mantissa * scale;
    if (value > kMaxCount) return fail("is more than 1e13");
    if (value != std::floor(value)) return fail("is not a whole number");
    return static_cast<uint64_t>(value);
}

CLI::Option* addCount(CLI::App* sub, const std::string& name, uint64_t& value,
                      const std::string& help, uint64_t min) {
    return sub->add_option(name, value, help)->transform(countValidator(min))->capture_default_str();
}

CLI::Option* addRays(CLI::App* sub, uint64_t& rays, const std::string& help, uint64_t min) {
    return addCount(sub, "-n,--rays", rays, help, min);
}

CLI::Option* addMaxMemory(CLI::App* sub, uint64_t& bytes, const std::string& what) {
    return addCount(sub, "--max-memory", bytes,
                    "the most memory the " + what +
                        " may take, in bytes (4G: 4e9; default: the machine's memory); the "
                        "estimate is checked before any work",
                    0);
}

void addRunControls(CLI::App* sub, int& threads, uint64_t& seed) {
    sub->add_option("--threads", threads, "worker threads (0: all cores)")
        ->check(CLI::Range(0, 4096))
        ->capture_default_str();
    sub->add_option("--seed", seed, "random seed (the same seed gives the same result with any "
                                    "number of threads)")
        ->check(CLI::Validator(
            [](std::string& s) -> std::string {
                // A whole number in [0, 2^64 - 1]; "-1" or a larger number would wrap or
                // saturate silently.
                uint64_t v = 0;
                const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
                if (ec != std::errc() || end != s.data() + s.size())
                    return "--seed " + s + " is not a whole number from 0 to 18446744073709551615";
                return {};
            },
            "UINT in [0 - 18446744073709551615]"))
        ->capture_default_str();
}

// A closed range that also refuses nan (CLI::Range lets it through: every comparison is
// false).
CLI::Validator finiteRange(double lo, double hi) {
    return CLI::Validator(
        [lo, hi](std::string& s) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(s.c_str(), &end);
            if (end == s.c_str() || *end != '\0' || !(v >= lo && v <= hi))
                return "value " + s + " not in range [" + CLI::detail::to_string(lo) + " - " +
                       CLI::detail::to_string(hi) + "]";
            return {};
        },
        "FLOAT in [" + CLI::detail::to_string(lo) + " - " + CLI::detail::to_string(hi) + "]");
}

void addTransportFlags(CLI::App* sub, TransportFlags& f) {
    sub->add_option("--mode", f.mode, "split (every Fresnel branch) or random (one branch)")
        ->check(CLI::IsMember({"split", "random"}))
        ->capture_default_str();
    sub->add_option("--min-flux", f.minRelativeFlux,
                    "a branch below this share of its ray's emitted flux, after every bounce "
                    "(both modes), plays Russian roulette: kept at --rescue-flux or ended")
        ->check(finiteRange(0.0, 1.0))
        ->capture_default_str();
    sub->add_option("--rescue-flux", f.rescueRelativeFlux,
                    "the share of its ray's emitted flux a branch keeps when it survives the "
                    "roulette below --min-flux (at least --min-flux)")
        ->check(finiteRange(0.0, 1.0))
        ->capture_default_str();
    sub->add_flag("--min-flux-cut", f.minFluxCut,
                  "cut the branches below --min-flux instead of playing roulette: faster, "
                  "biased low (the budget's 'cut' line bounds what the detectors lack)");
    sub->add_option("--max-split-depth", f.maxSplitDepth, "split mode: deepest split followed")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    sub->add_option("--roulette", f.roulette,
                    "Russian roulette below this share of the ray's flux (0: off)")
        ->check(finiteRange(0.0, 1.0))
        ->capture_default_str();
    sub->add_option("--max-segments", f.maxSegments, "segments per branch before it is culled")
        ->check(CLI::Range(1, 100000000))
        ->capture_default_str();
}

void applyTransportFlags(const TransportFlags& f, TransportOptions& options) {
    // Split mode follows both Fresnel branches: without a flux floor or roulette nothing but
    // the depth bounds the tree, 2^depth branches per ray (2^64 by default).
    if (f.mode != "random" && !(f.minRelativeFlux > 0.0) && !(f.roulette > 0.0) &&
        f.maxSplitDepth > kMaxUnculledSplitDepth)
        throw ModelError("--min-flux",
                         "0 in split mode leaves each ray's tree of Fresnel branches bounded "
                         "only by --max-split-depth (" +
                             std::to_string(f.maxSplitDepth) + ": up to 2^" +
                             std::to_string(f.maxSplitDepth) +
                             " branches per ray): give --min-flux > 0 (default 1e-4), "
                             "--roulette > 0, --max-split-depth <= " +
                             std::to_string(kMaxUnculledSplitDepth) + ", or --mode random");
    options.mode =
        f.mode == "random" ? TransportOptions::Mode::Random : TransportOptions::Mode::Split;
    if (!f.minFluxCut && f.minRelativeFlux > 0.0 && f.rescueRelativeFlux < f.minRelativeFlux) {
        std::ostringstream text;
        text << "must be at least --min-flux (" << f.minRelativeFlux << "), or the roulette's "
             << "survivors would carry less than they had; " << f.rescueRelativeFlux << " given";
        throw ModelError("--rescue-flux", text.str());
    }
    options.minRelativeFlux = f.minRelativeFlux;
    options.rescueRelativeFlux = f.minFluxCut ? 0.0 : f.rescueRelativeFlux;
    options.maxSplitDepth = f.maxSplitDepth;
    options.rouletteRelativeFlux = f.roulette;
    options.maxSegments = f.maxSegments;
}

CLI::Option* addOutputFolder(CLI::App* sub, std::string& folder, const std::string& defaultName) {
    return sub->add_option("-o,--output", folder,
                           "output folder, created as needed (default: ./" + defaultName +
                               "; with --json, files are written only when -o is given)");
}

CLI::Option* addOutputFile(CLI::App* sub, std::string& file, const std::string& what) {
    return sub->add_option("-o,--output", file, what)->capture_default_str();
}

void addReportFlags(CLI::App* sub, bool& json, bool& quiet) {
    sub->add_flag("--json", json, "print the report as JSON on standard output");
    sub->add_flag("--quiet", quiet,
                  "no progress and no list of written files (warnings and errors remain)");
}

CLI::Option* addFields(CLI::App* sub, std::vector<std::string>& fields) {
    return sub->add_option("--field", fields,
                           "field X,Y in degrees (object mm for a finite object), repeatable: a "
                           "collimated (or point) 1 W source per field, replacing the scene's");
}

std::vector<std::pair<double, double>> parseFields(const std::vector<std::string>& fields) {
    std::vector<std::pair<double, double>> out;
    for (size_t k = 0; k < fields.size(); ++k) {
        std::istringstream in(fields[k]);
        double x = 0, y = 0;
        char comma = 0;
        if (!(in >> x >> comma >> y) || comma != ',' || !(in >> std::ws).eof() ||
            !std::isfinite(x) || !std::isfinite(y))
            throw ParseError({"--field " + std::to_string(k + 1), 1, 1},
                             "expected X,Y (two numbers separated by a comma), got '" +
                                 fields[k] + "'");
        out.emplace_back(x, y);
    }
    return out;
}

std::optional<std::pair<double, double>> parseRange(const std::string& text, std::string* error) {
    const size_t colon = text.find(':');
    auto number = [](const std::string& t, double& v) {
        char* end = nullptr;
        v = std::strtod(t.c_str(), &end);
        return !t.empty() && end == t.c_str() + t.size() && std::isfinite(v);
    };
    double lo = 0.0, hi = 0.0;
    if (colon == std::string::npos || !number(text.substr(0, colon), lo) ||
        !number(text.substr(colon + 1), hi)) {
        if (error) *error = "'" + text + "' is not LO:HI (two numbers, such as 1e-9:3e-7)";
        return std::nullopt;
    }
    if (!(lo > 0.0 && hi > lo)) {
        if (error) *error = "'" + text + "' needs 0 < LO < HI (the colour scale is logarithmic)";
        return std::nullopt;
    }
    return std::make_pair(lo, hi);
}

void addPreviewFlags(CLI::App* sub, PreviewFlags& f) {
    sub->add_option("--decades", f.decades,
                    "PNG previews: the colour scale spans D decades below the brightest pixel "
                    "(default: chosen from the light shown, docs/cli.md)")
        ->check(CLI::Validator(
            [](std::string& s) -> std::string {
                char* end = nullptr;
                const double v = std::strtod(s.c_str(), &end);
                if (end == s.c_str() || *end != '\0' || !(v > 0.0 && v <= 30.0))
                    return "--decades " + s + " is not a number of decades in (0, 30]";
                return {};
            },
            "D in (0, 30]"));
    sub->add_option("--range", f.range,
                    "PNG previews: the colour scale from LO to HI, in the preview's unit "
                    "(irradiance, flux per mm^2)")
        ->check(CLI::Validator(
            [](std::string& s) -> std::string {
                std::string error;
                return parseRange(s, &error) ? std::string() : "--range " + error;
            },
            "LO:HI"));
    sub->get_option("--range")->excludes(sub->get_option("--decades"));
}

PreviewScale previewScale(const PreviewFlags& f) {
    PreviewScale s;
    s.decades = f.decades;
    if (!f.range.empty()) {
        std::string error;
        const auto r = parseRange(f.range, &error);
        if (!r) throw ParseError({"--range", 0, 0}, error);
        s.lo = r->first;
        s.hi = r->second;
    }
    return s;
}

void requireWritableFolder(const std::filesystem::path& folder, const std::string& option,
                           const std::string& shown) {
    namespace fs = std::filesystem;
    auto fail = [&](const std::string& why) {
        throw ParseError({option + " " + (shown.empty() ? folder.string() : shown), 0, 0}, why);
    };
    if (folder.empty()) fail("the output folder is empty");
    std::error_code ec;
    // The folder itself if it exists, else the nearest folder above it that does.
    fs::path at = fs::absolute(folder, ec);
    if (ec) fail("not a usable path: " + ec.message());
    while (!fs::exists(at, ec)) {
        if (!at.has_parent_path() || at.parent_path() == at) fail("no folder above it exists");
        at = at.parent_path();
    }
    if (!fs::is_directory(at, ec))
        fail(at == fs::absolute(folder) ? "is a file, not a folder"
                                        : at.string() + " is a file, not a folder");
    if (::access(at.c_str(), W_OK | X_OK) != 0)
        fail("veil may not write in " + at.string() + " (" + std::strerror(errno) + ")");
    // Some folders pass access() and still refuse new files (/proc, /sys): try one.
    const fs::path probe = at / (".veil-write-test-" + std::to_string(::getpid()));
    std::FILE* f = std::fopen(probe.c_str(), "wb");
    if (!f) fail("veil cannot create files in " + at.string() + " (" + std::strerror(errno) + ")");
    std::fclose(f);
    fs::remove(probe, ec);
}

std::filesystem::path outputFolder(const std::string& given, const std::string& defaultName,
                                   bool json) {
    std::filesystem::path folder = !given.empty() ? std::filesystem::path(given)
                                   : json         ? std::filesystem::path()
                                                  : std::filesystem::path(defaultName);
    if (!folder.empty()) requireWritableFolder(folder, "-o");
    return folder;
}

void WrittenFiles::print(std::ostream& os) const {
    if (files_.empty()) return;
    // The folder every file shares, if any: listed once.
    auto under = [](const std::filesystem::path& p, const std::filesystem::path& base) {
        return std::mismatch(base.begin(), base.end(), p.begin(), p.end()).first == base.end();
    };
    std::filesystem::path common = files_.front().parent_path();
    for (const auto& f : files_)
        while (!common.empty() && !under(f.parent_path(), common)) common = common.parent_path();
    os << "wrote " << files_.size() << (files_.size() == 1 ? " file" : " files");
    if (!common.empty()) os << " in " << common.string();
    os << ":";
    // Files in the shared folder by name; those in subfolders as "images/ (40 files)".
    std::vector<std::pair<std::string, size_t>> entries;
    for (const auto& f : files_) {
        const std::filesystem::path rel = common.empty() ? f : f.lexically_relative(common);
        const bool nested = std::distance(rel.begin(), rel.end()) > 1;
        const std::string name = nested ? rel.begin()->string() + "/" : rel.string();
        auto it = std::find_if(entries.begin(), entries.end(),
                               [&](const auto& e) { return e.first == name; });
        if (it == entries.end())
            entries.emplace_back(name, 1);
        else
            ++it->second;
    }
    for (size_t k = 0; k < entries.size(); ++k) {
        os << (k ? ", " : " ") << entries[k].first;
        if (entries[k].first.back() == '/')
            os << " (" << entries[k].second << (entries[k].second == 1 ? " file)" : " files)");
    }
    os << "\n";
}

void writePicture(const Picture& picture, const std::filesystem::path& stem, int widthPx,
                  WrittenFiles& written) {
    const std::filesystem::path svg = stem.string() + ".svg", png = stem.string() + ".png";
    picture.writeSvg(svg);
    written.add(svg);
    picture.writePng(png, widthPx);
    written.add(png);
}

void printReport(const std::string& jsonText, const std::string& text,
                 const WrittenFiles& written, bool json, bool quiet) {
    if (json) {
        nlohmann::json j = nlohmann::json::parse(jsonText);
        j["files"] = written.json();
        std::cout << j.dump(2) << "\n";
    } else {
        // --quiet drops the progress and the list of files, never the results.
        std::cout << text << "\n";
        if (!quiet) written.print(std::cout);
    }
}

namespace {

std::string& commandLine() {
    static std::string line;
    return line;
}

struct FileStamp {
    uint64_t bytes = 0;
    uint32_t crc = 0;
};

std::optional<FileStamp> stampOf(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) return std::nullopt;
    FileStamp s;
    std::vector<char> buffer(size_t{1} << 20);
    while (in) {
        in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
        const auto got = static_cast<size_t>(in.gcount());
        s.crc = crc32(reinterpret_cast<const uint8_t*>(buffer.data()), got, s.crc);
        s.bytes += got;
    }
    return s;
}

std::string hex8(uint32_t v) {
    std::ostringstream os;
    os << std::hex << std::setw(8) << std::setfill('0') << v;
    return os.str();
}

// NAME.EXT.tmp or NAME.EXT.partial with EXT a type veil writes.
bool leftoverTemporary(const std::filesystem::path& p) {
    const std::string ext = p.extension().string();
    if (ext != ".tmp" && ext != ".partial") return false;
    const std::string inner = p.stem().extension().string();
    for (const char* e : {".exr", ".png", ".svg", ".json", ".csv", ".md", ".vrdb", ".obj", ".ply",
                          ".txt", ".checkpoint"})
        if (inner == e) return true;
    return false;
}

}  // namespace

void setCommandLine(int argc, char** argv) {
    std::string line;
    for (int i = 0; i < argc; ++i) {
        const std::string a = argv[i];
        if (i) line += ' ';
        line += a.find_first_of(" \t'\"") == std::string::npos ? a : "'" + a + "'";
    }
    commandLine() = line;
}

namespace {

std::string hostName() {
    char name[256] = {};
    return gethostname(name, sizeof name - 1) == 0 ? std::string(name) : std::string("?");
}

// Takes the folder's lock (kRunLock) or throws naming the run that holds it; a lock left by a
// process of this host that no longer runs is removed first.
std::filesystem::path lockFolder(const std::filesystem::path& folder) {
    const std::filesystem::path lock = folder / kRunLock;
    const std::string host = hostName();
    for (int attempt = 0; attempt < 3; ++attempt) {
        const int fd = ::open(lock.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
        if (fd >= 0) {
            const std::string text = std::to_string(getpid()) + " " + host + " " + commandLine();
            const bool ok = ::write(fd, text.data(), text.size()) == ssize_t(text.size());
            ::close(fd);
            if (!ok) {
                std::error_code ec;
                std::filesystem::remove(lock, ec);
                throw std::runtime_error("cannot write the lock " + lock.string());
            }
            return lock;
        }
        if (errno != EEXIST)
            throw std::runtime_error("cannot lock " + folder.string() +
                                     " for this run: " + std::strerror(errno));
        std::ifstream in(lock);
        long long pid = 0;
        std::string owner, command;
        in >> pid >> owner;
        std::getline(in >> std::ws, command);
        in.close();
        const bool gone =
            owner == host && pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
        if (gone) {
            std::error_code ec;
            std::filesystem::remove(lock, ec);
            std::cerr << "veil: note: removed the lock of a run that no longer runs (process "
                      << pid << ": " << command << ") from " << folder.string() << "\n";
            continue;
        }
        if (pid <= 0 && attempt == 0) {
            // Being written this very moment by the run that took it: look again.
            usleep(100000);
            continue;
        }
        throw UsageError(folder.string() + ": another veil run is writing into this folder (" +
                         (pid > 0
                              ? "process " + std::to_string(pid) + " on " + owner + ": " + command
                              : "its lock " + lock.string() + " names no process") +
                         "); wait for it to finish, or choose another -o (if no such run is "
                         "writing there, remove " +
                         lock.string() + ")");
    }
    throw UsageError(folder.string() + ": cannot take the folder's lock " + lock.string());
}

}  // namespace

WrittenFiles::WrittenFiles(WrittenFiles&& o) noexcept
    : files_(std::move(o.files_)), folder_(std::move(o.folder_)), lock_(std::move(o.lock_)) {
    o.lock_.clear();
}

WrittenFiles& WrittenFiles::operator=(WrittenFiles&& o) noexcept {
    if (this != &o) {
        unlock();
        files_ = std::move(o.files_);
        folder_ = std::move(o.folder_);
        lock_ = std::move(o.lock_);
        o.lock_.clear();
    }
    return *this;
}

WrittenFiles::~WrittenFiles() { unlock(); }

void WrittenFiles::unlock() {
    if (lock_.empty()) return;
    std::error_code ec;
    std::filesystem::remove(lock_, ec);
    lock_.clear();
}

void WrittenFiles::beginRun(const std::filesystem::path& folder, bool keepFiles,
                            const std::vector<std::filesystem::path>& keep) {
    namespace fs = std::filesystem;
    folder_ = folder;
    if (folder.empty()) return;
    // The folder its files go into, made now so that the lock holds from here on.
    fs::create_directories(folder);
    if (lock_.empty()) lock_ = lockFolder(folder);
    const fs::path manifest = folder / kRunManifest;
    if (fs::exists(manifest)) {
        // Unreadable JSON gives a discarded value: only the manifest itself goes then.
        std::ifstream in(manifest);
        const nlohmann::json old = nlohmann::json::parse(in, nullptr, false);
        in.close();
        // The manifest goes first: from here on the folder holds no finished run.
        std::error_code ec;
        fs::remove(manifest, ec);
        if (ec)
            throw std::runtime_error("cannot remove the older run's manifest " + manifest.string() +
                                     ": " + ec.message());
        if (!keepFiles && old.is_object() && old.contains("files") && old["files"].is_array()) {
            for (const auto& f : old["files"]) {
                if (!f.is_object() || !f.contains("name") || !f["name"].is_string()) continue;
                const fs::path rel = f["name"].get<std::string>();
                // Only files inside the folder, named relative to it.
                if (rel.is_absolute() || rel.empty() || *rel.begin() == "..") continue;
                const fs::path file = folder / rel;
                if (!fs::is_regular_file(file)) continue;
                const auto stamp = stampOf(file);
                const bool same = stamp && f.value("bytes", uint64_t{0}) == stamp->bytes &&
                                  f.value("crc32", std::string()) == hex8(stamp->crc);
                if (same)
                    fs::remove(file, ec);
                else
                    std::cerr << "veil: warning: " << file.string()
                              << " was written by an older run into this folder and changed "
                                 "since; kept\n";
            }
        }
    }
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(folder, ec);
         !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
        if (it.depth() > 1) it.disable_recursion_pending();
        std::error_code removed;
        const bool kept = std::any_of(keep.begin(), keep.end(), [&](const fs::path& k) {
            std::error_code same;
            return fs::equivalent(k, it->path(), same);
        });
        if (it->is_regular_file() && leftoverTemporary(it->path()) && !kept)
            fs::remove(it->path(), removed);
    }
}

void WrittenFiles::finishRun() {
    namespace fs = std::filesystem;
    if (folder_.empty()) return;
    nlohmann::json files = nlohmann::json::array();
    const fs::path base = fs::absolute(folder_).lexically_normal();
    for (const fs::path& f : files_) {
        const auto stamp = stampOf(f);
        if (!stamp) continue;
        const fs::path rel = fs::absolute(f).lexically_normal().lexically_relative(base);
        const bool inside = !rel.empty() && *rel.begin() != "..";
        files.push_back({{"name", inside ? rel.string() : fs::absolute(f).string()},
                         {"bytes", stamp->bytes},
                         {"crc32", hex8(stamp->crc)}});
    }
    const std::time_t now = std::time(nullptr);
    char when[32] = {};
    std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    std::random_device device;
    const uint64_t id = (uint64_t{device()} << 32) ^ device();
    std::ostringstream idText;
    idText << std::hex << std::setw(16) << std::setfill('0') << id;
    const nlohmann::json manifest = {
        {"run_id", idText.str()},
        {"veil", kVeilVersion},
        {"command", commandLine()},
        {"finished", when},
        {"note", "the files of one finished veil run, as written (CRC-32 as zlib computes it); "
                 "a file of this folder not listed here belongs to no finished run"},
        {"files", files}};
    writeTextFile(folder_ / kRunManifest, manifest.dump(2) + "\n");
    unlock();
}

nlohmann::json WrittenFiles::json() const {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& f : files_) j.push_back(f.string());
    return j;
}

}  // namespace veil::cli
