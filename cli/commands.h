#pragma once
// Subcommands of the veil executable.

#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cli/options.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"

namespace veil::cli {

struct CommonOptions {
    std::vector<std::string> glassCatalogs;
    // --set KEY=VALUE: edits of the scene (and its lens) file, applied whenever a command
    // reads it, as sweep's --vary applies its values (docs/cli.md).
    std::vector<std::string> sets;
};
// One command's words (`render SCENE --passes 2`, without the program name) parsed by the
// command line's own definitions: `declare` adds that command (addRenderCommand and its
// options), --set and --glass-catalog land in common. UsageError when they do not parse. For
// callers that run a command's steps themselves (the Python module).
void parseCommandWords(const std::vector<std::string>& words, CommonOptions& common,
                       const std::function<void(CLI::App&)>& declare);
// Built-in catalogs, VEIL_GLASS_PATH and every --glass-catalog file.
GlassCatalog loadCatalog(const CommonOptions& common);
// The --set edits; a value without KEY= is a ParseError naming it.
std::vector<SceneEdit> sceneEdits(const CommonOptions& common);
// readSceneFile() with the --set edits.
SceneSpec readScene(const CommonOptions& common, const std::string& path,
                    const GlassCatalog& catalog);
// Caps the worker threads while the result lives (threads <= 0: all cores, returns null).
std::unique_ptr<tbb::global_control> limitThreads(int threads);
// The scene's warnings and errors on standard error: import notes, parts left out, and a
// detector that looks misplaced (analysis/lens/detector_checks.h), and a note naming the
// uncoated lens faces (uncoatedFacesNote).
void reportSceneNotes(const PreparedScene& scene);
// The lines a command prints of an import report, each once: the glass substitutions first
// (an unknown glass replaced or missing, and the glass a legacy name was taken as), then the
// other warnings and errors in the report's order, then the commands of the file veil does not
// read, on one line when there are several. Other infos are left to veil info.
std::vector<std::string> importNoteLines(const std::vector<ImportNote>& notes);
// The lens faces in air left uncoated (PropertyTable::uncoatedFaces), named with their count
// and what to do; empty when every one is coated. Faces are uncoated by default, and a bare
// lens reflects about 4 % at each: a multicoated lens studied uncoated looks tens of times
// worse than it is.
std::string uncoatedFacesNote(const PreparedScene& scene);
// The import warnings of a scene file (its lens's and the fit's), on standard error, for the
// commands that build their scenes inside a study (pst, sweep, glare).
void reportImportWarnings(const SceneSpec& spec);
// The scene of a command that traces: its sources replaced by one beam per --field when
// given; a scene without [[source]] gets one beam per system field (said on standard error).
std::unique_ptr<PreparedScene> prepareTracedScene(const CommonOptions& common,
                                                  const std::string& file,
                                                  const std::vector<std::string>& fields,
                                                  const GlassCatalog& catalog,
                                                  const SceneOptions& options = {});

struct InfoOptions {
    std::string file;
    bool json = false;
    bool quiet = false;
    std::string aim = "real";
    int rings = 8;
};
void addInfoCommand(CLI::App& app, InfoOptions& options);
int runInfo(const CommonOptions& common, const InfoOptions& options);

// veil export-lens FILE -o lens.toml: a lens file (Zemax, CODE V, or veil's own) as a veil
// lens file (lensdata/toml_writer.h), with --set edits applied; on standard output without -o.
struct ExportLensOptions {
    std::string file;
    std::string output;  // the TOML file; empty: standard output
    bool json = false;
    bool quiet = false;
};
void addExportLensCommand(CLI::App& app, ExportLensOptions& options);
int runExportLens(const CommonOptions& common, const ExportLensOptions& options);

struct LayoutOptions {
    std::string file;
    std::string output;  // folder: layout.svg, layout.png
    int widthPx = 2000;
    bool noMechanics = false;
    bool json = false;
    bool quiet = false;
};
void addLayoutCommand(CLI::App& app, LayoutOptions& options);
int runLayout(const CommonOptions& common, const LayoutOptions& options);

struct ExportOptions {
    std::string file;
    std::string output = "scene.obj";
    double chordToleranceMm = 0.01;
    bool noMechanics = false;
    bool json = false;
    bool quiet = false;
};
void addExportCommand(CLI::App& app, ExportOptions& options);
int runExport(const CommonOptions& common, const ExportOptions& options);

struct ViewOptions {
    std::string file;
    std::string output = "scene.html";
    std::string where;  // empty: no ray paths
    int first = 100;
    uint64_t rays = 1000000;  // per source, at most
    std::vector<std::string> fields;
    uint64_t batch = 20000;
    std::string colour = "flux";
    std::string mode = "split";
    double minRelativeFlux = 1e-4;
    int threads = 0;
    uint64_t seed = 1;
    double chordToleranceMm = 0.05;
    bool noMechanics = false;
    bool json = false;
    bool quiet = false;
};
void addViewCommand(CLI::App& app, ViewOptions& options);
int runView(const CommonOptions& common, const ViewOptions& options);

struct SweepOptions {
    std::string file;
    std::vector<std::string> vary;  // KEY=VALUES
    bool zip = false;
    std::string measure = "trace";
    uint64_t photons = 100000;
    uint64_t raysPerPixel = 16;
    std::string detector;
    uint64_t rays = 0;
    int batches = 16;
    std::string output;  // folder; default ./sweep
    std::vector<std::string> fields;
    int threads = 0;
    uint64_t seed = 1;
    TransportFlags transport;
    std::vector<std::string> where;
    bool prune = false;
    bool json = false;
    bool quiet = false;
};
void addSweepCommand(CLI::App& app, SweepOptions& options);
int runSweepCommand(const CommonOptions& common, const SweepOptions& options);

struct PstOptions {
    std::string file;
    std::string angles;
    std::string measure = "trace";
    uint64_t photons = 100000;
    uint64_t raysPerPixel = 16;
    double azimuthDeg = 0.0;
    uint64_t rays = 0;
    int batches = 16;
    std::string output;  // folder; default ./pst
    int threads = 0;
    uint64_t seed = 1;
    TransportFlags transport;
    std::vector<std::string> where;
    bool json = false;
    bool quiet = false;
};
void addPstCommand(CLI::App& app, PstOptions& options);
int runPstCommand(const CommonOptions& common, const PstOptions& options);

struct ObjectsOptions {
    std::string file;
    uint64_t rays = 20000;
    std::string source, detector;
    std::vector<std::string> fields;
    bool includeOptical = false;
    std::string rank = "product";
    int top = 8;
    std::string output;  // folder; default ./objects
    int threads = 0;
    uint64_t seed = 1;
    TransportFlags transport;
    bool json = false;
    bool quiet = false;
};
void addObjectsCommand(CLI::App& app, ObjectsOptions& options);
int runObjectsCommand(const CommonOptions& common, const ObjectsOptions& options);

struct ScatterOptions {
    std::string file;
    std::vector<std::string> properties;
    std::vector<double> wavelengthsNm;
    bool writeBsdf = false;
    std::string output;  // folder; default ./scatter
    bool json = false;
    bool quiet = false;
};
void addScatterCommand(CLI::App& app, ScatterOptions& options);
int runScatterCommand(const CommonOptions& common, const ScatterOptions& options);

struct GlareOptions {
    std::string file;
    double spotDeg = 0.5;
    double fieldDeg = 80.0;
    std::vector<std::string> fields;
    std::vector<double> fNumbers;
    int passes = 8;
    uint64_t photons = 100000;
    uint64_t raysPerPixel = 64;
    int pixels = 8;
    std::string gsf = "axis";
    double gsfRadiusMm = 0.0;
    int gsfPixels = 128;
    std::string output;  // folder; default ./glare
    int threads = 0;
    uint64_t seed = 1;
    bool json = false;
    bool quiet = false;
};
void addGlareCommand(CLI::App& app, GlareOptions& options);
int runGlareCommand(const CommonOptions& common, const GlareOptions& options);

}  // namespace veil::cli
