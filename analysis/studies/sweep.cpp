#include "analysis/studies/sweep.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analysis/ghosts/ghost_tracer.h"
#include "analysis/lens/default_scene.h"
#include "analysis/pictures/chart.h"
#include "analysis/reports/format.h"
#include "analysis/runs/render_run.h"
#include "analysis/runs/stray_light_run.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/input_file.h"
#include "lensdata/output_file.h"
#include "lensdata/toml_document.h"
#include "tracer/runtime/fingerprint.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/transport/interaction.h"

namespace veil {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Ranges longer than this are a mistake (a step of 1e-9 typed for 1e-3).
constexpr size_t kMaxValues = 10000;

std::optional<double> number(const std::string& s) {
    double v = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
    return v;
}

// Shortest text that reads back to the same double, without float noise from the range
// arithmetic: a value within 1e-12 of a 12-significant-digit rounding is written rounded.
std::string numberText(double v) {
    std::ostringstream os;
    os << std::setprecision(12) << v;
    const double rounded = std::stod(os.str());
    if (std::abs(rounded - v) <= 1e-12 * std::max(std::abs(v), 1e-300)) v = rounded;
    char buf[64];
    const auto [end, ec] = std::to_chars(buf, buf + sizeof(buf), v);
    return std::string(buf, end);
}

std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> out;
    std::string cur;
    for (char c : s) {
        if (c == sep) {
            out.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    out.push_back(cur);
    return out;
}

// FNV-1a, 64 bit: a stable fingerprint of a file's text.
std::string textHash(const std::filesystem::path& path) {
    const uint64_t h = fnv1a64(readInputFile(path).value_or(""));
    std::ostringstream os;
    os << std::hex << std::setw(16) << std::setfill('0') << h;
    return os.str();
}

// The measured scatter tables (`scatter = { model = "tabulated", brdf/btdf = "x.bsdf" }`)
// a document's [properties.NAME] tables name, by path relative to it.
void addTableHashes(const TomlDocument& doc, const std::filesystem::path& dir,
                    nlohmann::json& tables) {
    const auto props = doc.root().get("properties");
    if (!props || !props->isTable()) return;
    for (auto&& [name, node] : props->asTable().table()) {
        const auto* scatter = node.as_table() ? node.as_table()->get("scatter") : nullptr;
        if (!scatter || !scatter->as_table()) continue;
        for (const char* key : {"brdf", "btdf"})
            if (const auto* f = scatter->as_table()->get(key); f && f->is_string()) {
                const std::filesystem::path path = dir / f->as_string()->get();
                tables[path.lexically_normal().string()] = textHash(path);
            }
    }
}

// The files a variant depends on: the scene and, when it names them, its lens file, its
// material libraries and the scatter tables either names.
nlohmann::json inputHashes(const std::filesystem::path& scene) {
    nlohmann::json j;
    j["scene"] = textHash(scene);
    try {
        if (scene.extension() == ".toml") {
            TomlDocument doc = TomlDocument::fromFile(scene);
            if (const auto lens = doc.root().get("lens"); lens && lens->isString())
                j["lens"] = textHash(scene.parent_path() / lens->asString());
            nlohmann::json tables = nlohmann::json::object();
            addTableHashes(doc, scene.parent_path(), tables);
            if (const auto m = doc.root().get("materials")) {
                std::vector<TomlValue> files;
                if (m->isArray()) files = m->asArray();
                if (m->isString()) files.push_back(*m);
                for (const TomlValue& f : files) {
                    if (!f.isString()) continue;
                    const std::filesystem::path path = scene.parent_path() / f.asString();
                    j["materials"][path.lexically_normal().string()] = textHash(path);
                    addTableHashes(TomlDocument::fromFile(path), path.parent_path(), tables);
                }
            }
            if (!tables.empty()) j["scatter_tables"] = tables;
        }
    } catch (const std::exception&) {
        // Unreadable here: readSceneFile reports it for the variant.
    }
    return j;
}

double numOf(const nlohmann::json& j) { return j.is_number() ? j.get<double>() : kNaN; }

}  // namespace

// Axes

std::vector<std::string> parseSweepValues(const std::string& text, const std::string& origin) {
    auto fail = [&](const std::string& m) -> void { throw ParseError({origin, 0, 0}, m); };
    if (text.empty()) fail("no values after '='");
    std::vector<std::string> out;
    const std::vector<std::string> range = split(text, ':');
    if (range.size() == 1) {
        for (const std::string& v : split(text, ',')) {
            if (v.empty()) fail("an empty value in the list '" + text + "'");
            out.push_back(v);
        }
        return out;
    }
    if (range.size() != 3)
        fail("a range is START:STOP:STEP or START:STOP:xFACTOR, not '" + text + "'");
    const auto start = number(range[0]), stop = number(range[1]);
    if (!start || !stop) fail("the ends of the range '" + text + "' must be numbers");
    const bool geometric = !range[2].empty() && (range[2][0] == 'x' || range[2][0] == '*');
    const auto step = number(geometric ? range[2].substr(1) : range[2]);
    if (!step) fail("the step of the range '" + text + "' must be a number");
    if (geometric) {
        if (!(*start > 0.0) || !(*stop > 0.0) || !(*step > 0.0) || *step == 1.0)
            fail("a geometric range needs positive ends and a factor other than 1: '" + text + "'");
        const double f = *stop >= *start ? *step : 1.0 / *step;
        if ((*stop > *start) != (f > 1.0) && *stop != *start)
            fail("the factor of '" + text + "' moves away from its end");
        const double n = std::log(*stop / *start) / std::log(f);
        if (n + 1 > kMaxValues) fail("'" + text + "' has more than 10000 values");
        for (int k = 0; k <= static_cast<int>(std::floor(n + 1e-9)); ++k)
            out.push_back(numberText(*start * std::pow(f, k)));
        return out;
    }
    if (*step == 0.0) fail("the step of '" + text + "' is 0");
    if ((*stop - *start) * *step < 0.0) fail("the step of '" + text + "' moves away from its end");
    const double n = (*stop - *start) / *step;
    if (n + 1 > kMaxValues) fail("'" + text + "' has more than 10000 values");
    for (int k = 0; k <= static_cast<int>(std::floor(n + 1e-9)); ++k)
        out.push_back(numberText(*start + k * *step));
    return out;
}

SweepAxis parseSweepAxis(const std::string& option) {
    SweepAxis a;
    a.option = "--vary " + option;
    const size_t eq = option.find('=');
    if (eq == std::string::npos || eq == 0)
        throw ParseError({a.option, 0, 0},
                         "expected KEY=VALUES, as in "
                         "properties.black.reflectance=0.01,0.05,0.1");
    a.key = option.substr(0, eq);
    a.values = parseSweepValues(option.substr(eq + 1), a.option);
    return a;
}

std::vector<std::vector<std::string>> sweepVariants(const SweepSpec& spec) {
    std::vector<std::vector<std::string>> out;
    if (spec.axes.empty()) return out;
    if (spec.zip) {
        const size_t n = spec.axes.front().values.size();
        for (const SweepAxis& a : spec.axes)
            if (a.values.size() != n)
                throw ParseError({a.option, 0, 0},
                                 "--zip pairs the values of every --vary: this one has " +
                                     std::to_string(a.values.size()) + ", the first " +
                                     std::to_string(n));
        for (size_t i = 0; i < n; ++i) {
            std::vector<std::string> v;
            for (const SweepAxis& a : spec.axes) v.push_back(a.values[i]);
            out.push_back(std::move(v));
        }
        return out;
    }
    std::vector<size_t> index(spec.axes.size(), 0);
    while (true) {
        std::vector<std::string> v;
        for (size_t k = 0; k < spec.axes.size(); ++k) v.push_back(spec.axes[k].values[index[k]]);
        out.push_back(std::move(v));
        size_t k = spec.axes.size();
        while (k > 0) {
            --k;
            if (++index[k] < spec.axes[k].values.size()) break;
            index[k] = 0;
            if (k == 0) return out;
        }
    }
}

// Running

namespace {

std::vector<SceneEdit> editsOf(const SweepSpec& spec, const std::vector<std::string>& values) {
    std::vector<SceneEdit> edits = spec.baseEdits;
    for (size_t k = 0; k < spec.axes.size(); ++k)
        edits.push_back(
            {spec.axes[k].key, values[k], "--vary " + spec.axes[k].key + "=" + values[k]});
    return edits;
}

nlohmann::json fingerprint(const SweepSpec& spec, const nlohmann::json& hashes,
                           const std::vector<std::string>& values) {
    const TransportOptions& t = spec.transport;
    nlohmann::json j;
    j["format"] = 1;
    j["measure"] = std::string(toString(spec.measure));
    j["detector"] = spec.detector;
    if (spec.measure == SweepMeasure::Render) {
        std::ostringstream render;
        render << spec.render;
        j["render"] = render.str();
    }
    j["inputs"] = hashes;
    for (const SceneEdit& e : spec.baseEdits) j["set"][e.key] = e.value;
    for (size_t k = 0; k < spec.axes.size(); ++k) j["values"][spec.axes[k].key] = values[k];
    j["rays_per_source"] = spec.raysPerSource;
    j["batches"] = spec.batches;
    j["seed"] = t.seed;
    j["mode"] = t.mode == TransportOptions::Mode::Random ? "random" : "split";
    j["min_flux"] = t.minRelativeFlux;
    j["rescue_flux"] = t.rescueRelativeFlux;  // 0: cut below min_flux
    j["max_split_depth"] = t.maxSplitDepth;
    j["roulette"] = t.rouletteRelativeFlux;
    j["max_segments"] = t.maxSegments;
    j["where"] = spec.where;
    j["prune"] = spec.prune;
    j["fields_deg"] = spec.fieldsDeg;
    return j;
}

// The quantities of a run: each detector's total and criterion layers.
std::vector<std::string> quantityNames(const std::vector<StrayLightRow>& rows) {
    std::vector<std::string> names;
    for (const StrayLightRow& r : rows)
        names.push_back(r.layer.empty() ? r.detector : r.detector + ": " + r.layer);
    return names;
}

}  // namespace

std::string_view toString(SweepMeasure m) {
    switch (m) {
        case SweepMeasure::Trace:
            return "trace";
        case SweepMeasure::Render:
            return "render";
        case SweepMeasure::Ghosts:
            return "ghosts";
    }
    return "?";
}

namespace {

// One variant as measured, with the quantities it measured and, when it was traced (not read
// back), the record to save as variants/<k>.json.
struct Measured {
    SweepVariant variant;
    std::vector<std::string> quantities, criteria;
    std::string unit, record;

    // Between ranks (tracer/runtime/ranks.h).
    Bytes pack() const {
        ByteWriter w;
        const SweepVariant& v = variant;
        w.put(int32_t(v.index));
        w.put(uint64_t(v.values.size()));
        for (const std::string& x : v.values) w.putString(x);
        w.putString(v.error);
        w.put(uint8_t(v.resumed));
        w.put(uint8_t(v.geometryReused));
        w.put(v.seconds);
        w.put(uint64_t(v.batchValues.size()));
        for (const auto& b : v.batchValues) w.putVector(b);
        for (const auto* list : {&quantities, &criteria}) {
            w.put(uint64_t(list->size()));
            for (const std::string& x : *list) w.putString(x);
        }
        w.putString(unit);
        w.putString(record);
        return w.take();
    }
    static Measured unpack(const Bytes& bytes) {
        ByteReader r(bytes);
        Measured m;
        SweepVariant& v = m.variant;
        v.index = r.get<int32_t>();
        v.values.resize(r.get<uint64_t>());
        for (std::string& x : v.values) x = r.getString();
        v.error = r.getString();
        v.resumed = r.get<uint8_t>() != 0;
        v.geometryReused = r.get<uint8_t>() != 0;
        v.seconds = r.get<double>();
        v.batchValues.resize(r.get<uint64_t>());
        for (auto& b : v.batchValues) b = r.getVector<double>();
        for (auto* list : {&m.quantities, &m.criteria}) {
            list->resize(r.get<uint64_t>());
            for (std::string& x : *list) x = r.getString();
        }
        m.unit = r.getString();
        m.record = r.getString();
        if (!r.done()) throw std::runtime_error("a sweep variant from another rank is damaged");
        return m;
    }
};

// Every option checked before anything is read or built.
void checkSweepSpec(const SweepSpec& spec) {
    if (spec.axes.empty()) throw ModelError("sweep", "nothing to vary: give at least one --vary");
    const bool ghosts = spec.measure == SweepMeasure::Ghosts;
    if (!ghosts && spec.batches < 2)
        throw ParseError({"--batches", 0, 0},
                         "a sweep needs at least 2 batches (render: passes) for its errors");
    if (spec.measure == SweepMeasure::Trace &&
        spec.raysPerSource < static_cast<uint64_t>(spec.batches))
        throw ParseError({"-n", 0, 0}, "fewer rays (" + std::to_string(spec.raysPerSource) +
                                           ") than batches (" + std::to_string(spec.batches) + ")");
    if (ghosts && !spec.where.empty())
        throw ParseError({"--where", 0, 0},
                         "criteria split traced or rendered light: --measure ghosts has its own "
                         "(each ghost's), see veil ghosts");
    if (ghosts && spec.prune)
        throw ParseError({"--prune", 0, 0}, "--prune needs --measure trace or render");
    if (spec.measure == SweepMeasure::Render) {
        RenderOptions checked = spec.render;
        if (checked.initialRadiusMm <= 0.0) checked.initialRadiusMm = 1.0;  // set per scene
        try {
            checked.check();
        } catch (const std::invalid_argument& e) {
            throw ParseError({"--measure render", 0, 0}, e.what());
        }
    }
    for (size_t a = 0; a < spec.axes.size(); ++a)
        for (size_t b = 0; b < a; ++b)
            if (spec.axes[a].key == spec.axes[b].key)
                throw ParseError({spec.axes[a].option, 0, 0},
                                 spec.axes[a].key + " is varied twice (also by " +
                                     spec.axes[b].option + "): give its values once");
}

// One batch's values of a variant's quantities, as a measure hands them over.
using Record = std::function<void(int batch, const std::vector<std::string>& names,
                                  const std::vector<std::string>& criteria,
                                  const std::string& unit, const std::vector<double>& values)>;

// A sweep under way: its variants, the geometry a transport-only sweep shares, and the steps
// that measure, save, gather and compare them.
class Sweeper {
  public:
    Sweeper(const SweepSpec& spec, const GlassCatalog& catalog)
        : spec_(spec), catalog_(catalog), variants_(sweepVariants(spec)) {}
    SweepResult run();

  private:
    std::string label(size_t k) const;
    void progress(size_t k, int batchesDone) const;
    Measured measure(size_t k);
    // A finished variant of an earlier run with the same fingerprint, read back.
    void readBack(size_t k, const nlohmann::json& print, Measured& m) const;
    // The variant traced, rendered or estimated anew; its record for the folder.
    void measureAnew(size_t k, const nlohmann::json& print, Measured& m);
    PreparedScene& prepare(SweepVariant& v, std::unique_ptr<PreparedScene>& own);
    void measureTrace(const PreparedScene& scene, const Record& record) const;
    void measureRender(const PreparedScene& scene, const std::string& unit,
                       const Record& record) const;
    void measureGhosts(const PreparedScene& scene, const std::string& unit,
                       const Record& record) const;
    // Variant k into the result, from this rank or another, saved and checked against the
    // first variant's quantities.
    void take(size_t k, Measured m);
    // Values and the changes against the first variant, batch by batch.
    void compare();

    const SweepSpec& spec_;
    const GlassCatalog& catalog_;
    const std::vector<std::vector<std::string>> variants_;
    bool transportOnly_ = true;
    nlohmann::json hashes_;
    std::filesystem::path store_;
    std::unique_ptr<PreparedScene> shared_;  // transport-only sweeps: the geometry, built once
    SweepResult result_;
};

std::string Sweeper::label(size_t k) const {
    std::string label;
    for (size_t a = 0; a < spec_.axes.size(); ++a)
        label += (a ? ", " : "") + spec_.axes[a].key + "=" + variants_[k][a];
    return label;
}

void Sweeper::progress(size_t k, int batchesDone) const {
    if (!spec_.progress) return;
    spec_.progress({"sweep: variant " + std::to_string(k + 1) + " of " +
                        std::to_string(variants_.size()) + " (" + label(k) + ")",
                    static_cast<uint64_t>(batchesDone), static_cast<uint64_t>(result_.batches),
                    "batches"});
}

Measured Sweeper::measure(size_t k) {
    Measured m;
    m.variant.index = static_cast<int>(k);
    m.variant.values = variants_[k];
    progress(k, 0);
    const nlohmann::json print = fingerprint(spec_, hashes_, m.variant.values);
    readBack(k, print, m);
    if (!m.variant.resumed) measureAnew(k, print, m);
    return m;
}

void Sweeper::readBack(size_t k, const nlohmann::json& print, Measured& m) const {
    const std::filesystem::path saved = store_ / (std::to_string(k) + ".json");
    if (!std::filesystem::exists(saved)) return;
    SweepVariant& v = m.variant;
    try {
        std::ifstream in(saved);
        const nlohmann::json j = nlohmann::json::parse(in);
        if (j.at("fingerprint") != print) return;
        v.resumed = true;
        v.error = j.value("error", "");
        if (!v.error.empty()) return;
        m.quantities = j.at("quantities").get<std::vector<std::string>>();
        m.criteria = j.at("criteria").get<std::vector<std::string>>();
        m.unit = j.at("unit").get<std::string>();
        for (const auto& q : j.at("batch_values")) {
            std::vector<double> b;
            for (const auto& x : q) b.push_back(numOf(x));
            v.batchValues.push_back(std::move(b));
        }
    } catch (const std::exception&) {
        m = Measured{};  // unreadable: traced again
        m.variant.index = static_cast<int>(k);
        m.variant.values = variants_[k];
    }
}

PreparedScene& Sweeper::prepare(SweepVariant& v, std::unique_ptr<PreparedScene>& own) {
    SceneSpec file = readSceneFile(spec_.scene, catalog_, editsOf(spec_, v.values));
    if (!spec_.fieldsDeg.empty())
        setFieldSources(file, catalog_, spec_.fieldsDeg);
    else if (file.sources.empty())
        addSystemFieldSources(file, catalog_);
    if (transportOnly_ && shared_) {
        shared_->replaceTransport(std::move(file), catalog_);
        v.geometryReused = true;
        return *shared_;
    }
    own = PreparedScene::build(std::move(file), catalog_);
    return *own;
}

void Sweeper::measureTrace(const PreparedScene& scene, const Record& record) const {
    StrayLightSpec run;
    run.raysPerSource = spec_.raysPerSource;
    run.transport = spec_.transport;
    run.where = spec_.where;
    run.prune = spec_.prune;
    runStrayLightBatches(scene, run, spec_.batches, [&](int b, const StrayLightResult& r) {
        const std::vector<StrayLightRow> rows = r.report();
        std::vector<std::string> criteria;
        std::vector<double> values;
        for (const StrayLightRow& row : rows) {
            criteria.push_back(row.criterion);
            values.push_back(row.flux);
        }
        record(b, quantityNames(rows), criteria, r.fluxUnit, values);
    });
}

void Sweeper::measureRender(const PreparedScene& scene, const std::string& unit,
                            const Record& record) const {
    RenderRunSpec run;
    run.options = spec_.render;
    run.options.seed = spec_.transport.seed;
    run.options.prune = spec_.prune;
    run.stop.passes = spec_.batches;
    run.detector = spec_.detector;
    run.where = spec_.where;
    RenderRun render(scene, run);  // checks the scene (a detector, a source) first
    const std::string d =
        spec_.detector.empty() ? scene.transport().images[0].geometry().name : spec_.detector;
    std::vector<std::string> names{d + ": render"}, criteria{""};
    for (int c = 0; c < kRenderComponents; ++c) {
        names.push_back(d + ": " + std::string(toString(RenderComponent(c))));
        criteria.push_back("");
    }
    for (size_t k = 0; k < spec_.where.size(); ++k) {
        names.push_back(d + ": where" + std::to_string(k + 1));
        criteria.push_back(spec_.where[k]);
    }
    render.run([&](const RenderPassEvent& e) {
        const RenderPassTotals t = passTotals(*e.rendered);
        std::vector<double> values{t.total()};
        for (double c : t.components) values.push_back(c);
        for (double c : t.criteria) values.push_back(c);
        record(e.pass - 1, names, criteria, unit, values);
    });
}

void Sweeper::measureGhosts(const PreparedScene& scene, const std::string& unit,
                            const Record& record) const {
    GhostOptions go;
    go.detector = spec_.detector;
    const GhostTracer tracer(scene.geometry(), scene.transport(), catalog_, go);
    const GhostAnalysis a = tracer.analyse();
    double all = 0.0;
    for (const GhostEstimate& g : a.ghosts) all += g.flux();
    const std::string& d = a.detector;
    // The brightest ghost may be another pair in each variant.
    record(0, {d + ": nominal", d + ": ghosts", d + ": brightest ghost"},
           {nominalCriterion(d), a.allGhostsCriterion, ""}, unit,
           {a.nominal.flux(), all, a.ghosts.empty() ? 0.0 : a.ghosts.front().flux()});
}

void Sweeper::measureAnew(size_t k, const nlohmann::json& print, Measured& m) {
    SweepVariant& v = m.variant;
    const auto started = std::chrono::steady_clock::now();
    try {
        std::unique_ptr<PreparedScene> own;
        const PreparedScene& prepared = prepare(v, own);
        // One batch's values: the first names the quantities.
        const Record record = [&](int b, const std::vector<std::string>& names,
                                  const std::vector<std::string>& criteria,
                                  const std::string& unit, const std::vector<double>& values) {
            if (b == 0) {
                m.quantities = names;
                m.criteria = criteria;
                m.unit = unit;
                v.batchValues.assign(values.size(), {});
            }
            for (size_t q = 0; q < values.size(); ++q) v.batchValues[q].push_back(values[q]);
            progress(k, b + 1);
        };
        const TransportView& ts = prepared.transport().view;
        const std::string unit = ts.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
        if (spec_.measure == SweepMeasure::Trace)
            measureTrace(prepared, record);
        else if (spec_.measure == SweepMeasure::Render)
            measureRender(prepared, unit, record);
        else
            measureGhosts(prepared, unit, record);
        if (transportOnly_ && !shared_) shared_ = std::move(own);
    } catch (const std::exception& e) {
        v.error = e.what();
        v.batchValues.clear();
    }
    v.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    nlohmann::json j;
    j["fingerprint"] = print;
    j["error"] = v.error;
    j["seconds"] = v.seconds;
    j["quantities"] = m.quantities;
    j["criteria"] = m.criteria;
    j["unit"] = m.unit;
    j["batch_values"] = nlohmann::json::array();
    for (const auto& q : v.batchValues) {
        nlohmann::json b = nlohmann::json::array();
        for (double x : q) b.push_back(jsonNumber(x));
        j["batch_values"].push_back(b);
    }
    m.record = j.dump(1) + "\n";
}

void Sweeper::take(size_t k, Measured m) {
    SweepVariant& v = m.variant;
    if (!m.record.empty()) writeTextFile(store_ / (std::to_string(k) + ".json"), m.record);
    if (v.error.empty()) {
        if (result_.quantities.empty()) {
            result_.quantities = m.quantities;
            result_.criteria = m.criteria;
            result_.unit = m.unit;
        } else if (m.quantities != result_.quantities) {
            v.error =
                "its detectors differ from the first variant's, so the rows cannot be "
                "compared";
            v.batchValues.clear();
        }
    }
    result_.variants.push_back(std::move(v));
}

void Sweeper::compare() {
    const bool ghosts = spec_.measure == SweepMeasure::Ghosts;
    const SweepVariant& first = result_.variants.front();
    for (SweepVariant& v : result_.variants) {
        if (!v.error.empty()) continue;
        for (size_t q = 0; q < v.batchValues.size(); ++q) {
            SweepValue m;
            const BatchMean own = batchMean(v.batchValues[q]);
            m.value = own.value;
            m.error = ghosts ? 0.0 : own.error;  // the sequential estimate is exact
            if (first.error.empty() && q < first.batchValues.size() &&
                first.batchValues[q].size() == v.batchValues[q].size()) {
                std::vector<double> d;
                for (size_t b = 0; b < v.batchValues[q].size(); ++b)
                    d.push_back(v.batchValues[q][b] - first.batchValues[q][b]);
                const BatchMean change = batchMean(d);
                m.change = change.value;
                m.changeError = ghosts ? 0.0 : change.error;
            } else {
                m.change = m.changeError = kNaN;
            }
            v.measured.push_back(m);
        }
    }
}

SweepResult Sweeper::run() {
    // Every edit checked before anything is built: a key that names nothing stops the sweep.
    checkSceneEdits(spec_.scene, spec_.baseEdits);
    for (const SweepAxis& a : spec_.axes)
        for (const std::string& v : a.values)
            checkSceneEdits(spec_.scene, {{a.key, v, "--vary " + a.key + "=" + v}});
    for (const SweepAxis& a : spec_.axes)
        transportOnly_ = transportOnly_ && editsTransportOnly(a.key);
    for (const SweepAxis& a : spec_.axes) result_.keys.push_back(a.key);
    result_.batches = spec_.measure == SweepMeasure::Ghosts ? 1 : spec_.batches;
    result_.measure = std::string(toString(spec_.measure));
    hashes_ = inputHashes(spec_.scene);
    store_ = spec_.folder / "variants";
    const Ranks& ranks = spec_.ranks;
    if (ranks.root()) std::filesystem::create_directories(store_);
    // Across ranks variant k is measured on rank k mod K; rank 0 takes the variants in order
    // (its own as it measures them, the others' as they arrive: a round of K variants at a
    // time), saves them and compares them with the first.
    for (size_t k = 0; k < variants_.size(); ++k) {
        if (ranks.owns(k)) {
            Measured m = measure(k);
            if (ranks.root())
                take(k, std::move(m));
            else
                ranks.send(0, m.pack());
        } else if (ranks.root()) {
            progress(k, 0);
            Measured m = Measured::unpack(ranks.receive(static_cast<int>(k % ranks.size())));
            progress(k, result_.batches);
            take(k, std::move(m));
        }
    }
    if (!ranks.root()) return std::move(result_);  // its variants went to rank 0
    compare();
    return std::move(result_);
}

}  // namespace

SweepResult runSweep(const SweepSpec& spec, const GlassCatalog& catalog) {
    checkSweepSpec(spec);
    return Sweeper(spec, catalog).run();
}

// Tables

ReportTable SweepResult::table() const {
    // Every measured quantity of every variant, the variant's values repeated on its rows; a
    // variant that could not be run has one row with its error.
    ReportTable table(std::vector<ReportColumn>{{"variant", "variant"}});
    for (const std::string& k : keys) table.addColumn({k, k});
    table.addColumn({"quantity", "quantity"});
    ReportColumn criterion{"criterion"};
    criterion.markdown = false;
    table.addColumn(criterion);
    table.addColumn({"value", "value (" + unit + ")"});
    ReportColumn error{"error"};
    error.markdown = false;
    table.addColumn(error);
    table.addColumn({"change", "change against variant 0"});
    for (const char* k : {"change_error", "unit", "status"}) {
        ReportColumn c{k};
        c.markdown = false;
        table.addColumn(c);
    }
    auto pm = [](double v, double e) {
        if (!std::isfinite(v)) return std::string("-");
        std::string s = scientific(v, 4);
        if (std::isfinite(e) && e > 0.0) s += " +- " + scientific(e, 2);
        return s;
    };
    auto number = [](double v, int digits, std::string shown = "") {
        return ReportCell::number(v, scientific(v, digits), shown, shown);
    };
    for (const SweepVariant& v : variants) {
        std::vector<ReportCell> lead{ReportCell::count(v.index)};
        for (const std::string& x : v.values) lead.push_back(ReportCell::text(x));
        if (!v.error.empty()) {
            std::string e = v.error;
            std::replace(e.begin(), e.end(), '|', '/');
            std::replace(e.begin(), e.end(), '\n', ' ');
            // CSV: empty quantities, the error as the status; Markdown: "(not run)" and the
            // error (one line, no '|') in the value column.
            auto shown = [](const std::string& csv, const std::string& markdown) {
                ReportCell c = ReportCell::text(csv);
                c.markdown = c.terminal = markdown;
                return c;
            };
            std::vector<ReportCell> row = lead;
            row.push_back(shown("", "(not run)"));      // quantity
            row.push_back(shown("", ""));               // criterion
            row.push_back(shown("", "error: " + e));    // value
            row.push_back(shown("", ""));               // error
            row.push_back(shown("", "-"));              // change
            row.push_back(shown("", ""));               // change_error
            row.push_back(ReportCell::text(unit));
            row.push_back(ReportCell::text("error: " + v.error));
            table.addRow(std::move(row));
            continue;
        }
        for (size_t q = 0; q < v.measured.size(); ++q) {
            const SweepValue& m = v.measured[q];
            std::vector<ReportCell> row = lead;
            row.push_back(ReportCell::text(quantities[q]));
            row.push_back(ReportCell::text(criteria[q]));
            row.push_back(number(m.value, 6, pm(m.value, m.error)));
            row.push_back(number(m.error, 3));
            row.push_back(number(m.change, 6,
                                 v.index == 0 ? std::string("(reference)")
                                              : pm(m.change, m.changeError)));
            row.push_back(number(m.changeError, 3));
            row.push_back(ReportCell::text(unit));
            row.push_back(ReportCell::text(v.resumed ? "resumed" : "ok"));
            table.addRow(std::move(row));
        }
    }
    return table;
}

std::string SweepResult::csv() const { return table().csv(); }

std::string SweepResult::markdown() const {
    std::ostringstream os;
    os << table().markdown();
    bool anyCriterion = false;
    for (const std::string& c : criteria) anyCriterion = anyCriterion || !c.empty();
    if (anyCriterion) {
        os << "\n";
        for (size_t q = 0; q < quantities.size(); ++q)
            if (!criteria[q].empty()) os << "- " << quantities[q] << ": `" << criteria[q] << "`\n";
    }
    return os.str();
}

ReportTable SweepResult::variantTable() const {
    // One row per variant for the JSON report: its values, how it was measured, and every
    // quantity with its batch values.
    ReportTable table(std::vector<ReportColumn>{{"index"}});
    for (const std::string& k : keys) table.addColumn({"values/" + k});
    for (const char* k : {"error", "resumed", "geometry_reused", "seconds", "measured"})
        table.addColumn({k});
    for (const SweepVariant& v : variants) {
        std::vector<ReportCell> row{ReportCell::count(v.index)};
        for (const std::string& x : v.values) row.push_back(ReportCell::text(x));
        row.push_back(ReportCell::text(v.error));
        row.push_back(ReportCell::flag(v.resumed));
        row.push_back(ReportCell::flag(v.geometryReused));
        ReportCell seconds = ReportCell::text("");
        seconds.json = v.seconds;
        row.push_back(seconds);
        ReportCell measured = ReportCell::text("");
        measured.json = nlohmann::json::array();
        for (size_t q = 0; q < v.measured.size(); ++q) {
            const SweepValue& m = v.measured[q];
            nlohmann::json b = nlohmann::json::array();
            for (double x : v.batchValues[q]) b.push_back(jsonNumber(x));
            measured.json.push_back({{"quantity", quantities[q]},
                                     {"value", jsonNumber(m.value)},
                                     {"error", jsonNumber(m.error)},
                                     {"change", jsonNumber(m.change)},
                                     {"change_error", jsonNumber(m.changeError)},
                                     {"batch_values", b}});
        }
        row.push_back(measured);
        table.addRow(std::move(row));
    }
    return table;
}

std::string SweepResult::json() const {
    nlohmann::json j;
    j["keys"] = keys;
    j["quantities"] = quantities;
    j["criteria"] = criteria;
    j["unit"] = unit;
    j["measure"] = measure;
    j["batches"] = batches;
    j["variants"] = variantTable().json();
    return j.dump(2) + "\n";
}

// Plot

std::vector<std::filesystem::path> writeSweep(const SweepResult& r,
                                              const std::filesystem::path& folder) {
    std::filesystem::create_directories(folder);
    std::vector<std::filesystem::path> written;
    auto text = [&](const char* name, const std::string& body) {
        writeTextFile(folder / name, body);
        written.push_back(folder / name);
    };
    text("sweep.csv", r.csv());
    text("sweep.md", r.markdown());
    text("sweep.json", r.json());

    // x: the first axis's values (numbers, else categories in order of appearance); a series
    // per quantity and per combination of the other axes' values.
    std::vector<std::string> xTexts;
    for (const SweepVariant& v : r.variants)
        if (std::find(xTexts.begin(), xTexts.end(), v.values[0]) == xTexts.end())
            xTexts.push_back(v.values[0]);
    bool numeric = true;
    for (const std::string& t : xTexts) numeric = numeric && number(t).has_value();
    ChartSpec chart;
    chart.xLabel = r.keys[0];
    chart.yLabel = "flux on the detector (" + r.unit + ")";
    chart.title = "veil sweep: stray light against " + r.keys[0];
    if (!numeric) chart.xCategories = xTexts;
    std::vector<double> xs, ys;
    std::vector<std::string> seriesKeys;
    for (const SweepVariant& v : r.variants) {
        if (!v.error.empty()) continue;
        std::string others;
        for (size_t k = 1; k < r.keys.size(); ++k) others += ", " + r.keys[k] + "=" + v.values[k];
        const double x =
            numeric ? *number(v.values[0])
                    : static_cast<double>(std::find(xTexts.begin(), xTexts.end(), v.values[0]) -
                                          xTexts.begin());
        for (size_t q = 0; q < v.measured.size(); ++q) {
            const std::string key = r.quantities[q] + others;
            auto it = std::find(seriesKeys.begin(), seriesKeys.end(), key);
            if (it == seriesKeys.end()) {
                seriesKeys.push_back(key);
                ChartSeries s;
                s.label = key;
                if (!r.criteria[q].empty()) s.label += " (" + r.criteria[q] + ")";
                // A detector's total is dashed when its criteria are drawn too (the rest
                // often lies on it).
                // The detector's total (trace: its name alone; render: "D: render") is
                // dashed, drawn under its parts.
                const std::string& name = r.quantities[q];
                const bool total =
                    name.find(": ") == std::string::npos || name.ends_with(": render");
                s.dashed = total && r.quantities.size() > 1;
                chart.series.push_back(s);
                it = seriesKeys.end() - 1;
            }
            ChartSeries& s = chart.series[static_cast<size_t>(it - seriesKeys.begin())];
            s.x.push_back(x);
            s.y.push_back(v.measured[q].value);
            s.yError.push_back(v.measured[q].error);
            xs.push_back(x);
            ys.push_back(v.measured[q].value);
        }
    }
    if (chart.series.empty()) return written;  // every variant failed: nothing to plot
    chart.logX = numeric && chooseLogAxis(xs);
    chart.logY = chooseLogAxis(ys);
    const Picture pic = drawChart(chart);
    pic.writeSvg(folder / "sweep.svg");
    pic.writePng(folder / "sweep.png", 1600);
    written.push_back(folder / "sweep.svg");
    written.push_back(folder / "sweep.png");
    return written;
}

}  // namespace veil
