#pragma once
// What-if studies: one scene, some of its values varied, every variant measured the same way.
//
//   SweepSpec (scene file, axes KEY=VALUES, grid or zip, rays and batches, criteria)
//     --runSweep--> SweepResult: per variant its values, its stray light per quantity (each
//       detector's total and criterion layers) with the error, and the change against the
//       first variant with the error of the difference; a variant that cannot be built or
//       run is a row with its error message, and the sweep goes on.
//
// Common random numbers. Every variant is traced in the same `batches` batches of rays with
// the same seeds (batch b uses seed + b), so ray i of batch b starts the same way in every
// variant. The value is the mean over batches, its error the spread of the batch values; the
// change against the first variant is the mean of the batch differences, and its error their
// spread, which is far smaller than either error when the variants share most of their paths
// (a mount's reflectance changed: the same rays meet the mount).
//
// Keys are TOML paths into the scene file (TomlDocument::set: "properties.black.reflectance",
// "mechanics.baffles[1].z_mm", "source.sun.field_deg[2]", "system.surfaces.3.coating"),
// checked before anything is traced. Variants whose keys change only what the transport
// reads (editsTransportOnly: properties, [[assign]], sources) reuse the first variant's
// geometry (PreparedScene::replaceTransport); others build theirs.
//
// Resume. Every finished variant is written to folder/variants/<k>.json with a fingerprint of
// what it measured (the scene and lens file texts, its values, rays, batches, seed, transport
// options, criteria); a rerun with the same fingerprint reads it instead of tracing again.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "analysis/reports/progress.h"
#include "analysis/reports/report_table.h"
#include "tracer/render/render.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

class GlassCatalog;

struct SweepAxis {
    std::string key;
    std::vector<std::string> values;  // as the edit writes them
    std::string option;               // "--vary KEY=VALUES": names the axis in messages
};

// "KEY=VALUES" (the --vary option): VALUES is a list "0.001,0.01,0.3" (numbers or words), a
// linear range "10:60:5" (start:stop:step, stop included when a step lands on it), or a
// geometric one "0.001:1:x10" (start:stop:xFACTOR). Throws ParseError at "--vary ...".
SweepAxis parseSweepAxis(const std::string& option);
// The values of a range or list, as texts that read back to the same numbers.
std::vector<std::string> parseSweepValues(const std::string& text, const std::string& origin);

// How a variant is measured:
//   trace   forward Monte Carlo (veil trace) in `batches` batches of raysPerSource rays per
//           source: each detector's total and criterion layers
//   render  the bidirectional renderer (veil render) for `batches` passes: the rendered
//           detector's total and its components (visible, direct, caustic, secondary) and
//           criterion images; the dark mounts' scatter that forward rays find as speckle
//   ghosts  the sequential two-reflection ghost estimate (veil ghosts, no Monte Carlo): the
//           nominal image, all ghosts together and the brightest ghost on the detector;
//           deterministic, so its errors are 0
enum class SweepMeasure { Trace, Render, Ghosts };
std::string_view toString(SweepMeasure m);

struct SweepSpec {
    // Edits applied to every variant before its own (`--set`); a variant's value of the same
    // key wins.
    std::vector<SceneEdit> baseEdits;
    SweepMeasure measure = SweepMeasure::Trace;
    // Render: its options (the seed is transport.seed; passes = batches) and the detector
    // (empty: the first); ghosts: the detector. The learned aperture guide is off: guided
    // passes draw their pixel rays from the light found so far, which differs between
    // variants, and that would cost the variants their common random numbers. For the same
    // reason the small lit parts' points are split evenly over the parts.
    RenderOptions render = unguided();
    static RenderOptions unguided() {
        RenderOptions o;
        o.partSplitByLight = false;
        o.guideFraction = 0.0;
        o.photonGuideFraction = 0.0;
        o.scatterGuideFraction = 0.0;
        o.weightWindow = 0.0;
        return o;
    }
    std::string detector;
    std::filesystem::path scene;
    std::vector<SweepAxis> axes;
    bool zip = false;  // pair the axes' values (equal counts) instead of their grid
    // Collimated 1 W beams (degrees x, y) replacing the scene's sources (--field); empty:
    // the scene's sources, or one beam per system field when it has none.
    std::vector<std::pair<double, double>> fieldsDeg;
    // Per variant: raysPerSource rays per source in `batches` batches (seed + b); render:
    // `batches` passes; ghosts: one deterministic estimate (rays and batches unused).
    uint64_t raysPerSource = 0;
    int batches = 16;
    TransportOptions transport;      // its seed is the first batch's
    std::vector<std::string> where;  // criteria: one quantity each per detector, plus "rest"
    bool prune = false;
    std::filesystem::path folder;  // variants/<k>.json are kept here (resume)
    // Under mpirun (tracer/runtime/ranks.h): variant k is measured on rank k mod K, by that rank
    // alone with its threads, and rank 0 saves it and completes the result (the others
    // return theirs empty); every rank reads the scene and the folder's earlier variants.
    Ranks ranks = Ranks::alone();
    // Before each variant and after each batch (from the calling thread): one task per
    // variant, "sweep: variant 2 of 5 (KEY=VALUE)", its batches counted.
    ProgressSink progress;
};

// One variant's measurement of one quantity; NaN where nothing reached it.
struct SweepValue {
    double value = 0.0;
    double error = 0.0;   // 1 sigma, absolute
    double change = 0.0;  // value - the first variant's value (common random numbers)
    double changeError = 0.0;
};

struct SweepVariant {
    int index = 0;
    std::vector<std::string> values;   // per axis
    std::string error;                 // why it could not be built or run; empty when it ran
    bool resumed = false;              // read from folder/variants, not traced
    bool geometryReused = false;       // transport-only edits on the first variant's geometry
    double seconds = 0.0;              // building and tracing (0 when resumed)
    std::vector<SweepValue> measured;  // per quantity (empty on error)
    std::vector<std::vector<double>> batchValues;  // [quantity][batch]
};

struct SweepResult {
    std::vector<std::string> keys;        // per axis
    std::vector<std::string> quantities;  // "sensor", "sensor: where1", ..., "sensor: rest"
    std::vector<std::string> criteria;    // per quantity: the criterion text ("" for a total)
    std::string unit;                     // "W" or "lm"
    std::string measure;                  // "trace", "render" or "ghosts"
    int batches = 0;
    std::vector<SweepVariant> variants;

    // The tables: one row per variant and quantity.
    // One row per variant and quantity (analysis/reports/report_table.h): the CSV and the
    // Markdown table; the JSON report's variants, each with its quantities and batch values,
    // are variantTable()'s rows.
    ReportTable table() const;
    ReportTable variantTable() const;
    std::string csv() const;
    std::string markdown() const;
    std::string json() const;  // also holds each variant's batch values
};

// The variants of the spec's axes in order (grid: the last axis fastest).
std::vector<std::vector<std::string>> sweepVariants(const SweepSpec& spec);

// Checks every edit first (ParseError at the --vary option for a key that names nothing or a
// value of the wrong type; ModelError for an empty sweep), then measures the variants.
SweepResult runSweep(const SweepSpec& spec, const GlassCatalog& catalog);

// sweep.csv, sweep.md, sweep.json, sweep.png and sweep.svg in `folder` (the plot: every
// quantity against the first axis's values, a line per quantity and per value of the other
// axes, error bars; log axes where the values span a decade or more). Returns the paths.
std::vector<std::filesystem::path> writeSweep(const SweepResult& result,
                                              const std::filesystem::path& folder);

}  // namespace veil
