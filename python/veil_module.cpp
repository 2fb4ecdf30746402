// veil._veil: the C++ side of the Python module (python/veil/__init__.py is the user's side).
//
//   PreparedScene      a scene (or lens) built once from the texts read when veil.Scene was
//                      made, with its edits and --field beams: what trace and render run on
//   render(words, scene_for, progress)
//                      veil render's steps (cli/render_command.h) as values: the words parsed
//                      and checked by the command line's own definitions before the scene is
//                      built, then RenderRun (analysis/runs/render_run.h); the summary as a
//                      dict and the images as numpy arrays, files only into an output folder
//   trace(words, scene_for, progress)
//                      the same for veil trace (cli/trace_command.h, runStrayLight)
//   info(words, snapshots)
//                      veil info's report (analysis/lens/info_report.h) as a dict
//   run(args)          any other command in-process (cli/app.h), its standard output and
//                      error captured: exactly what the executable does with the same words
//   read_exr(path)     a detector EXR's layers as numpy arrays with their units
//   Lens               a lens file read once: real-ray traces and aimed rays as numpy arrays
//
// Errors raise veil.ParseError (file:line:col in the message), veil.ModelError (the object),
// veil.UsageError (the command line) or veil.VeilError (anything else), all VeilError.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "analysis/lens/info_report.h"
#include "analysis/reports/image_output.h"
#include "cli/app.h"
#include "cli/commands.h"
#include "cli/render_command.h"
#include "cli/trace_command.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/input_file.h"
#include "lensdata/toml_document.h"
#include "tracer/records/detector.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/ray_status.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace py = pybind11;

namespace {

// std::cout and std::cerr into strings while a command runs (one command at a time: the
// streams are the process's).
class CapturedStreams {
  public:
    CapturedStreams()
        : out_(std::cout.rdbuf(outText_.rdbuf())), err_(std::cerr.rdbuf(errText_.rdbuf())) {}
    ~CapturedStreams() {
        std::cout.rdbuf(out_);
        std::cerr.rdbuf(err_);
    }
    CapturedStreams(const CapturedStreams&) = delete;
    CapturedStreams& operator=(const CapturedStreams&) = delete;
    std::string out() const { return outText_.str(); }
    std::string err() const { return errText_.str(); }

  private:
    std::ostringstream outText_, errText_;
    std::streambuf* out_;
    std::streambuf* err_;
};

std::mutex& commandMutex() {
    static std::mutex m;
    return m;
}

// A command's result; on an exception, what it printed before failing travels with it.
struct CommandRun {
    int exitCode = 0;
    std::string out, err;
};

CommandRun run(std::vector<std::string> args, const veil::FileSnapshots& snapshots) {
    args.insert(args.begin(), "veil");
    std::lock_guard lock(commandMutex());
    const veil::FileSnapshotScope files(&snapshots);
    CommandRun r;
    std::exception_ptr failure;
    std::string printedErr;
    {
        py::gil_scoped_release noGil;
        CapturedStreams streams;
        try {
            r.exitCode = veil::cli::runCommandLine(args, /*rethrow=*/true);
        } catch (...) {
            failure = std::current_exception();
        }
        r.out = streams.out();
        r.err = streams.err();
    }
    if (failure) {
        // Warnings and notes printed before the error still reach the user.
        if (!r.err.empty())
            py::print(r.err, py::arg("end") = "",
                      py::arg("file") = py::module_::import("sys").attr("stderr"));
        std::rethrow_exception(failure);
    }
    return r;
}

// The texts of a scene file and of the lens file it names (`lens = "..."`), or of a lens
// file: what Scene holds so that its commands do not read the disk again.
veil::FileSnapshots snapshot(const std::filesystem::path& path) {
    veil::FileSnapshots s;
    const std::optional<std::string> text = veil::readInputFile(path);
    if (!text) throw veil::ParseError({path.string(), 0, 0}, "cannot open file");
    s[veil::snapshotKey(path)] = *text;
    if (path.extension() == ".toml") {
        const veil::TomlDocument doc = veil::TomlDocument::fromString(*text, path.string());
        if (const auto lens = doc.root().has("lens") ? doc.root().get("lens") : std::nullopt)
            if (const std::filesystem::path lensPath = path.parent_path() / lens->asString();
                veil::inputFileExists(lensPath))
                if (const auto lensText = veil::readInputFile(lensPath))
                    s[veil::snapshotKey(lensPath)] = *lensText;
    }
    return s;
}

py::array_t<double> image(const std::vector<double>& v, int width, int height) {
    py::array_t<double> a({height, width});
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
}

// A detector's layers (read from its EXR, or a run's images in memory) as numpy arrays.
py::dict exrDict(const veil::DetectorExr& e) {
    py::dict layers;
    for (const veil::ExrLayer& l : e.layers) {
        py::dict layer;
        layer["flux"] = image(l.value, e.width, e.height);
        layer["irradiance"] = image(l.irradiance, e.width, e.height);
        layer["variance"] = image(l.variance, e.width, e.height);
        layer["count"] = image(l.count, e.width, e.height);
        layer["total_flux"] = l.totalFlux;
        layer["total_relative_error"] = l.totalRelativeError;
        layers[py::str(l.name)] = layer;
    }
    py::dict d;
    d["detector"] = e.detector;
    d["flux_unit"] = e.fluxUnit;
    d["irradiance_unit"] = e.irradianceUnit;
    d["variance_unit"] = e.fluxUnit + "^2";
    d["count_unit"] = "rays";
    d["emitted_rays"] = e.emittedRays;
    d["width"] = e.width;
    d["height"] = e.height;
    d["detector_size_mm"] = py::make_tuple(e.detectorSizeMm.x, e.detectorSizeMm.y);
    d["pixel_size_mm"] = py::make_tuple(e.pixelSizeMm.x, e.pixelSizeMm.y);
    d["layers"] = layers;
    return d;
}

py::dict readExr(const std::filesystem::path& path) { return exrDict(veil::readDetectorExr(path)); }

template <class Image>
py::dict layersDict(const std::vector<std::pair<std::string, Image>>& named,
                    const veil::ExrInfo& info) {
    std::vector<veil::ImageLayer> layers;
    for (const auto& [name, im] : named) {
        if constexpr (std::is_pointer_v<Image>)
            layers.push_back({name, im});
        else
            layers.push_back({name, &im});
    }
    return exrDict(veil::detectorLayers(layers, info));
}

py::object fromJson(const nlohmann::json& j) {
    return py::module_::import("json").attr("loads")(j.dump());
}

// Warnings and notes a step wrote on standard error, passed on to sys.stderr.
void passOn(const std::string& err) {
    if (!err.empty())
        py::print(err, py::arg("end") = "",
                  py::arg("file") = py::module_::import("sys").attr("stderr"));
}

// Progress events to a Python callable (None: none). A callable that raises is reported as
// unraisable and the run goes on.
veil::ProgressSink progressSink(const py::object& progress) {
    if (progress.is_none()) return {};
    return [progress](const veil::ProgressEvent& e) {
        py::gil_scoped_acquire gil;
        try {
            py::dict d;
            d["task"] = e.task;
            d["done"] = e.done;
            d["total"] = e.total;
            d["unit"] = e.unit;
            d["state"] = e.state;
            d["eta_seconds"] = e.etaSeconds;
            progress(d);
        } catch (py::error_already_set& err) {
            err.discard_as_unraisable("veil progress callback");
        }
    };
}

std::vector<veil::SceneEdit> editsOf(const std::vector<std::pair<std::string, std::string>>& sets) {
    std::vector<veil::SceneEdit> edits;
    for (const auto& [key, value] : sets)
        edits.push_back({key, value, "set(" + key + ", " + value + ")"});
    return edits;
}

// A scene prepared once (veil.Scene's texts, edits and --field beams), as a command that
// traces prepares it (cli::prepareTracedScene): the default field sources of a bare lens
// included. Its notes and warnings go to sys.stderr.
class PreparedSceneHandle {
  public:
    PreparedSceneHandle(const std::string& path, const std::vector<std::string>& glassCatalogs,
                        const std::vector<std::string>& sets,
                        const std::vector<std::string>& fields,
                        const veil::FileSnapshots& snapshots) {
        std::lock_guard lock(commandMutex());
        const veil::FileSnapshotScope files(&snapshots);
        veil::cli::CommonOptions common;
        common.glassCatalogs = glassCatalogs;
        common.sets = sets;
        std::string err;
        std::exception_ptr failure;
        {
            py::gil_scoped_release noGil;
            CapturedStreams streams;
            try {
                const veil::GlassCatalog catalog = veil::cli::loadCatalog(common);
                scene_ = veil::cli::prepareTracedScene(common, path, fields, catalog);
                veil::cli::reportSceneNotes(*scene_);
            } catch (...) {
                failure = std::current_exception();
            }
            err = streams.err();
        }
        passOn(err);
        if (failure) std::rethrow_exception(failure);
    }
    const veil::PreparedScene& scene() const { return *scene_; }
    std::vector<std::string> detectors() const {
        std::vector<std::string> names;
        for (const veil::DetectorImage& d : scene_->transport().images)
            names.push_back(d.geometry().name);
        return names;
    }
    size_t sources() const { return scene_->transport().view.sources.size(); }

  private:
    std::unique_ptr<const veil::PreparedScene> scene_;
};

// The words of one command parsed by its own definitions (cli::parseCommandWords).
template <class Options>
Options parseWords(const std::vector<std::string>& words, void (*declare)(CLI::App&, Options&)) {
    Options o;
    veil::cli::CommonOptions common;
    veil::cli::parseCommandWords(words, common, [&](CLI::App& app) { declare(app, o); });
    return o;
}

// What a run as a value hands Python: its report (the command's --json, files included), its
// text, its images, the files it wrote.
py::dict runDict(nlohmann::json report, const veil::cli::WrittenFiles& written,
                 const std::string& text, const py::dict& images) {
    report["files"] = written.json();
    py::dict out;
    out["report"] = fromJson(report);
    out["text"] = text;
    out["images"] = images;
    out["files"] = fromJson(written.json());
    return out;
}

// veil render's steps: options checked, the scene asked for (scene_for(fields), built once
// per edits and fields by veil.Scene), the run, files only into -o.
py::dict renderValue(const std::vector<std::string>& words, const py::function& sceneFor,
                     const py::object& progress) {
    veil::cli::RenderCommandOptions o =
        parseWords<veil::cli::RenderCommandOptions>(words, veil::cli::addRenderCommand);
    o.json = true;  // no folder unless -o or --resume
    veil::RenderRunSpec spec = veil::cli::renderSpec(o);
    const std::filesystem::path dir = veil::cli::renderFolder(o);
    if (!dir.empty()) veil::cli::requireWritableFolder(dir, "-o");
    const py::object held = sceneFor(o.fields);  // alive while the run reads it
    const PreparedSceneHandle& scene = held.cast<const PreparedSceneHandle&>();
    spec.progress = progressSink(progress);
    std::optional<veil::cli::RenderCommandRun> run;
    {
        py::gil_scoped_release noGil;
        run.emplace(veil::cli::renderIntoFolder(scene.scene(), std::move(spec), o, dir));
    }
    const veil::RenderResult& r = run->result;
    py::dict images;
    images[py::str(r.detector)] =
        layersDict(r.imageLayers(), veil::ExrInfo{r.unit, static_cast<uint64_t>(r.passes())});
    return runDict(r.summary(), run->written, r.text(dir.string()), images);
}

// veil trace's steps, the same way.
py::dict traceValue(const std::vector<std::string>& words, const py::function& sceneFor,
                    const py::object& progress) {
    veil::cli::TraceOptions o =
        parseWords<veil::cli::TraceOptions>(words, veil::cli::addTraceCommand);
    veil::StrayLightSpec spec = veil::cli::traceSpec(o);
    const std::filesystem::path dir = veil::cli::outputFolder(o.output, "trace", /*json=*/true);
    const py::object held = sceneFor(o.fields);
    const PreparedSceneHandle& scene = held.cast<const PreparedSceneHandle&>();
    const std::string note = veil::cli::checkRayDatabase(scene.scene(), spec, o);
    if (!note.empty()) passOn("veil: --save-rays: " + note + "\n");
    spec.progress = progressSink(progress);
    std::optional<veil::cli::TraceCommandRun> run;
    {
        py::gil_scoped_release noGil;
        run.emplace(veil::cli::traceIntoFolder(scene.scene(), std::move(spec), o, dir));
    }
    const veil::StrayLightResult& r = run->result;
    py::dict images;
    for (size_t d = 0; d < r.images.size(); ++d)
        images[py::str(r.images[d].geometry().name)] =
            layersDict(r.imageLayers(d), veil::ExrInfo{r.fluxUnit, r.emittedRays});
    return runDict(r.summary(), run->written, r.text(), images);
}

// veil info's report (--set and --glass-catalog among the words).
py::object infoValue(const std::vector<std::string>& words, const veil::FileSnapshots& snapshots) {
    veil::cli::InfoOptions o;
    veil::cli::CommonOptions common;
    veil::cli::parseCommandWords(words, common,
                                 [&](CLI::App& app) { veil::cli::addInfoCommand(app, o); });
    std::lock_guard lock(commandMutex());
    const veil::FileSnapshotScope files(&snapshots);
    std::optional<veil::InfoReport> report;
    std::string err;
    std::exception_ptr failure;
    {
        py::gil_scoped_release noGil;
        CapturedStreams streams;
        try {
            const veil::GlassCatalog catalog = veil::cli::loadCatalog(common);
            report.emplace(veil::makeInfoReport(
                o.file, veil::cli::readScene(common, o.file, catalog).prescription, catalog,
                o.aim == "real" ? veil::AimMode::Real : veil::AimMode::Paraxial, o.rings));
        } catch (...) {
            failure = std::current_exception();
        }
        err = streams.err();
    }
    passOn(err);
    if (failure) std::rethrow_exception(failure);
    return fromJson(report->json());
}

// A lens read once (a lens file, or a scene file's lens), with its sequential model.
class Lens {
  public:
    Lens(const std::filesystem::path& path, const std::vector<std::string>& glassCatalogs,
         const std::vector<std::pair<std::string, std::string>>& sets,
         const veil::FileSnapshots& snapshots)
        : path_(path) {
        const veil::FileSnapshotScope files(&snapshots);
        veil::cli::CommonOptions common;
        common.glassCatalogs = glassCatalogs;
        const veil::GlassCatalog catalog = veil::cli::loadCatalog(common);
        veil::SceneSpec file = veil::readSceneFile(path, catalog, editsOf(sets));
        model_ = file.model;
    }

    std::string name() const { return model_->prescription().system.name; }
    std::vector<double> wavelengths() const {
        std::vector<double> w;
        for (int k = 0; k < model_->wavelengthCount(); ++k) w.push_back(model_->wavelengthNm(k));
        return w;
    }
    int primary() const { return model_->primaryWavelength(); }
    std::vector<std::string> surfaceNames() const {
        std::vector<std::string> n;
        for (const auto& s : model_->surfaces()) n.push_back(s.name);
        return n;
    }
    int stop() const { return model_->stopIndex(); }
    int image() const { return model_->imageIndex(); }

    // Real rays (global frame, mm) through the surfaces first..last.
    py::dict trace(py::array_t<double, py::array::c_style | py::array::forcecast> origins,
                   py::array_t<double, py::array::c_style | py::array::forcecast> directions,
                   std::optional<int> wavelength, int first, int last, bool clip,
                   bool recordPath) const {
        if (origins.ndim() != 2 || origins.shape(1) != 3 || directions.ndim() != 2 ||
            directions.shape(1) != 3 || origins.shape(0) != directions.shape(0))
            throw std::invalid_argument(
                "origins and directions must be arrays of the same shape (N, 3)");
        const int w = wavelengthIndex(wavelength);
        const int lastSurface = last < 0 ? model_->imageIndex() : last;
        if (first < 1 || first > model_->imageIndex() || lastSurface < first ||
            lastSurface > model_->imageIndex())
            throw std::invalid_argument("surfaces must satisfy 1 <= first <= last <= " +
                                        std::to_string(model_->imageIndex()));
        const py::ssize_t n = origins.shape(0);
        const auto o = origins.unchecked<2>();
        const auto d = directions.unchecked<2>();
        py::array_t<int> status(n), surface(n);
        py::array_t<double> position({n, py::ssize_t(3)}), direction({n, py::ssize_t(3)}), opl(n);
        const py::ssize_t surfaces = lastSurface - first + 1;
        py::array_t<double> path({recordPath ? n : 0, surfaces, py::ssize_t(3)});
        auto st = status.mutable_unchecked<1>();
        auto su = surface.mutable_unchecked<1>();
        auto po = position.mutable_unchecked<2>();
        auto di = direction.mutable_unchecked<2>();
        auto op = opl.mutable_unchecked<1>();
        auto pa = path.mutable_unchecked<3>();
        veil::SequentialTraceOptions options;
        options.firstSurface = first;
        options.lastSurface = lastSurface;
        options.clipApertures = clip;
        options.recordPath = recordPath;
        const double nan = std::numeric_limits<double>::quiet_NaN();
        {
            py::gil_scoped_release noGil;
            for (py::ssize_t i = 0; i < n; ++i) {
                veil::Ray ray{{o(i, 0), o(i, 1), o(i, 2)}, {d(i, 0), d(i, 1), d(i, 2)}};
                const double len = glm::length(ray.direction);
                if (len > 0.0) ray.direction /= len;
                const veil::SequentialRayResult r = veil::traceSequential(*model_, w, ray, options);
                st(i) = static_cast<int>(r.status);
                su(i) = r.surface;
                for (int k = 0; k < 3; ++k) {
                    po(i, k) = r.ray.origin[k];
                    di(i, k) = r.ray.direction[k];
                }
                op(i) = r.ok() ? r.opticalPathMm : nan;
                if (recordPath)
                    for (py::ssize_t s = 0; s < surfaces; ++s)
                        for (int k = 0; k < 3; ++k)
                            pa(i, s, k) = s < static_cast<py::ssize_t>(r.path.size())
                                              ? r.path[s].origin[k]
                                              : nan;
            }
        }
        py::dict out;
        out["status"] = status;
        out["surface"] = surface;
        out["position"] = position;
        out["direction"] = direction;
        out["optical_path"] = opl;
        if (recordPath) out["path"] = path;
        return out;
    }

    // Rays from a field point through pupil points (px, py in the unit disk), aimed as
    // `veil info` aims its spots: origins and directions in object space.
    py::dict aim(double fx, double fy,
                 py::array_t<double, py::array::c_style | py::array::forcecast> px,
                 py::array_t<double, py::array::c_style | py::array::forcecast> py_,
                 std::optional<int> wavelength, const std::string& mode) const {
        if (mode != "real" && mode != "paraxial")
            throw std::invalid_argument("aim must be 'real' or 'paraxial', not '" + mode + "'");
        if (px.ndim() != 1 || py_.ndim() != 1 || px.shape(0) != py_.shape(0))
            throw std::invalid_argument("px and py must be 1-D arrays of the same length");
        const int w = wavelengthIndex(wavelength);
        const veil::RayAimer aimer(*model_,
                                   mode == "real" ? veil::AimMode::Real : veil::AimMode::Paraxial);
        const py::ssize_t n = px.shape(0);
        py::array_t<double> origins({n, py::ssize_t(3)}), directions({n, py::ssize_t(3)});
        py::array_t<int> status(n);
        auto o = origins.mutable_unchecked<2>();
        auto d = directions.mutable_unchecked<2>();
        auto st = status.mutable_unchecked<1>();
        const auto x = px.unchecked<1>();
        const auto y = py_.unchecked<1>();
        {
            py::gil_scoped_release noGil;
            for (py::ssize_t i = 0; i < n; ++i) {
                const veil::AimedRay a = aimer.aim(fx, fy, x(i), y(i), w);
                st(i) = static_cast<int>(a.status);
                for (int k = 0; k < 3; ++k) {
                    o(i, k) = a.ray.origin[k];
                    d(i, k) = a.ray.direction[k];
                }
            }
        }
        py::dict out;
        out["origins"] = origins;
        out["directions"] = directions;
        out["status"] = status;
        return out;
    }

  private:
    int wavelengthIndex(std::optional<int> w) const {
        if (!w) return model_->primaryWavelength();
        if (*w < 0 || *w >= model_->wavelengthCount())
            throw std::invalid_argument("wavelength index " + std::to_string(*w) +
                                        " out of range: the lens has " +
                                        std::to_string(model_->wavelengthCount()));
        return *w;
    }

    std::filesystem::path path_;
    std::shared_ptr<const veil::SequentialModel> model_;
};

}  // namespace

PYBIND11_MODULE(_veil, m) {
    m.doc() = "veil's C++ core (use the veil package)";
    py::object base = py::reinterpret_borrow<py::object>(PyExc_RuntimeError);
    static py::exception<std::exception> veilError(m, "VeilError", base.ptr());
    static py::exception<veil::ParseError> parseError(m, "ParseError", veilError.ptr());
    static py::exception<veil::ModelError> modelError(m, "ModelError", veilError.ptr());
    static py::exception<veil::cli::UsageError> usageError(m, "UsageError", veilError.ptr());
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const veil::ParseError& e) {
            parseError(e.what());
        } catch (const veil::ModelError& e) {
            modelError(e.what());
        } catch (const veil::cli::UsageError& e) {
            usageError(e.what());
        } catch (const std::invalid_argument& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        } catch (const std::exception& e) {
            veilError(e.what());
        }
    });

    py::class_<CommandRun>(m, "CommandRun")
        .def_readonly("exit_code", &CommandRun::exitCode)
        .def_readonly("stdout", &CommandRun::out)
        .def_readonly("stderr", &CommandRun::err);
    m.def("snapshot", &snapshot, py::arg("path"),
          "The texts of a scene file and the lens file it names, keyed for run().");
    m.def("run", &run, py::arg("args"), py::arg("snapshots") = veil::FileSnapshots{},
          "Runs the veil command line with these words (without the program name); returns "
          "its exit code and captured output, raising VeilError subclasses on failure. Files "
          "in snapshots are read from there, not from the disk.");
    py::class_<PreparedSceneHandle>(m, "PreparedScene")
        .def(py::init<const std::string&, const std::vector<std::string>&,
                      const std::vector<std::string>&, const std::vector<std::string>&,
                      const veil::FileSnapshots&>(),
             py::arg("path"), py::arg("glass_catalogs"), py::arg("sets"), py::arg("fields"),
             py::arg("snapshots"))
        .def_property_readonly("detectors", &PreparedSceneHandle::detectors)
        .def_property_readonly("sources", &PreparedSceneHandle::sources);
    m.def("render", &renderValue, py::arg("words"), py::arg("scene_for"),
          py::arg("progress") = py::none(),
          "veil render's words run as values: {report, text, images, files}.");
    m.def("trace", &traceValue, py::arg("words"), py::arg("scene_for"),
          py::arg("progress") = py::none(),
          "veil trace's words run as values: {report, text, images, files}.");
    m.def("info", &infoValue, py::arg("words"), py::arg("snapshots"),
          "veil info's report as a dict.");
    m.def("read_exr", &readExr, py::arg("path"),
          "A detector EXR written by veil: its layers' flux, irradiance, variance and count "
          "as (rows, columns) float64 arrays, row 0 at the top, and their units.");

    py::class_<Lens>(m, "Lens")
        .def(py::init<const std::filesystem::path&, const std::vector<std::string>&,
                      const std::vector<std::pair<std::string, std::string>>&,
                      const veil::FileSnapshots&>(),
             py::arg("path"), py::arg("glass_catalogs") = std::vector<std::string>{},
             py::arg("sets") = std::vector<std::pair<std::string, std::string>>{},
             py::arg("snapshots") = veil::FileSnapshots{})
        .def_property_readonly("name", &Lens::name)
        .def_property_readonly("wavelengths_nm", &Lens::wavelengths)
        .def_property_readonly("primary_wavelength", &Lens::primary)
        .def_property_readonly("surface_names", &Lens::surfaceNames)
        .def_property_readonly("stop_surface", &Lens::stop)
        .def_property_readonly("image_surface", &Lens::image)
        .def("trace", &Lens::trace, py::arg("origins"), py::arg("directions"),
             py::arg("wavelength") = py::none(), py::arg("first_surface") = 1,
             py::arg("last_surface") = -1, py::arg("clip") = true, py::arg("record_path") = false)
        .def("aim", &Lens::aim, py::arg("field_x"), py::arg("field_y"), py::arg("px"),
             py::arg("py"), py::arg("wavelength") = py::none(), py::arg("mode") = "real");
    // The status codes of Lens.trace and Lens.aim, by value.
    py::list statuses;
    for (veil::RayStatus s :
         {veil::RayStatus::Ok, veil::RayStatus::Missed, veil::RayStatus::TotalInternalReflection,
          veil::RayStatus::Clipped, veil::RayStatus::Invalid})
        statuses.append(std::string(veil::toString(s)));
    m.attr("RAY_STATUS") = statuses;
}
