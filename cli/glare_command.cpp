// veil glare SCENE: the veiling glare index (ISO 9358) at field positions, its specular
// (ghost) and diffuse (scatter) parts, with errors (analysis/studies/glare.h, docs/glare.md).
//
//   veil glare examples/scenes/double_gauss_50mm_painted.toml -o out/glare
//   veil glare scene.toml --field 0,0 --field 0,15 --spot-deg 1 --passes 16
//
// Writes DIR/glare.md, glare.csv, glare.json and, for two positions or more, glare.png /
// glare.svg (VGI and its parts against the field angle). The table goes to standard output
// (or the JSON with --json), progress to standard error.

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "analysis/pictures/chart.h"
#include "analysis/studies/glare.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/output_file.h"

namespace veil::cli {

namespace {

// The glare spread functions, log-log: every position's total; with one position, its
// specular and diffuse parts too. The spot image's radius of the first position marked.
ChartSpec spreadChart(const GlareResult& result) {
    ChartSpec chart;
    chart.title = "Glare spread function: a point source's stray light around its image";
    chart.xLabel = "distance from the point source's image (mm)";
    chart.yLabel = "GSF (1/mm^2: irradiance over the disc's flux)";
    chart.logX = chart.logY = true;
    auto label = [](const GlareField& f) {
        std::ostringstream os;
        os << std::setprecision(4) << f.fieldDeg.x << ", " << f.fieldDeg.y << " deg, f/"
           << std::setprecision(3) << f.fNumber;
        return os.str();
    };
    size_t spreads = 0;
    for (const GlareField& f : result.fields) spreads += f.spread ? 1 : 0;
    for (const GlareField& f : result.fields) {
        if (!f.spread) continue;
        const GlareSpread& g = *f.spread;
        auto series = [&](const std::string& name, const std::vector<GlareValue>& v, bool dashed) {
            ChartSeries s{name, {}, {}, {}, dashed, false};
            for (size_t a = 0; a < v.size(); ++a) {
                s.x.push_back(spreadRadius(g.edgesMm[a], g.edgesMm[a + 1]));
                s.y.push_back(v[a].value);
                s.yError.push_back(v[a].error);
            }
            return s;
        };
        chart.series.push_back(series(spreads > 1 ? label(f) : "total", g.total, false));
        if (spreads == 1) {
            chart.series.push_back(series("specular (image and ghosts)", g.specular, true));
            chart.series.push_back(series("diffuse (scatter)", g.diffuse, true));
        }
    }
    for (const GlareField& f : result.fields)
        if (f.spread) {
            chart.xMarkers.push_back({f.spotImageRadiusMm, "spot image"});
            break;
        }
    return chart;
}

}  // namespace

void addGlareCommand(CLI::App& app, GlareOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "glare", "veiling glare index (ISO 9358) at field positions: ghosts and scatter");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    sub->add_option("--spot-deg", o.spotDeg, "angular diameter of the black spot")
        ->check(CLI::Range(1e-3, 20.0))
        ->capture_default_str();
    sub->add_option("--field-deg", o.fieldDeg,
                    "half angle of the bright Lambertian field about the axis")
        ->check(CLI::Range(1.0, 89.0))
        ->capture_default_str();
    addFields(sub, o.fields)
        ->description(
            "black spot position X,Y in degrees (repeatable; default: the axis and the lens's "
            "fields)");
    sub->add_option("--f-number", o.fNumbers,
                    "stop the lens down to this image-space F-number (repeatable; needs a "
                    "[mechanics] stop; default: the lens as given)")
        ->check(CLI::Range(0.1, 1000.0));
    sub->add_option("--passes", o.passes, "render passes per position and field")
        ->check(CLI::Range(2, 100000))
        ->capture_default_str();
    addCount(sub, "--photons", o.photons, "photons per pass");
    addCount(sub, "--rays-per-pixel", o.raysPerPixel, "backward rays per pixel per pass");
    sub->add_option("--pixels", o.pixels, "pixels per side of the measuring square")
        ->check(CLI::Range(1, 256))
        ->capture_default_str();
    sub->add_option("--gsf", o.gsf,
                    "where to measure the glare spread function (a point source's stray light): "
                    "at the positions on the axis, at all, or none")
        ->check(CLI::IsMember({"axis", "all", "none"}))
        ->capture_default_str();
    sub->add_option("--gsf-radius-mm", o.gsfRadiusMm,
                    "radius of the GSF's disc about the point's image (default: the image height "
                    "of the lens's largest field)")
        ->check(CLI::Range(1e-3, 1e4));
    sub->add_option("--gsf-pixels", o.gsfPixels, "pixels per side of the GSF's detector")
        ->check(CLI::Range(16, 2048))
        ->capture_default_str();
    addOutputFolder(sub, o.output, "glare");
    addRunControls(sub, o.threads, o.seed);
    addReportFlags(sub, o.json, o.quiet);
}

int runGlareCommand(const CommonOptions& common, const GlareOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    const std::filesystem::path dir = outputFolder(o.output, "glare", o.json);
    const SceneFile file = readScene(common, o.file, catalog);
    GlareSpec spec;
    for (const auto& [x, y] : parseFields(o.fields)) spec.fieldsDeg.push_back(Vec2(x, y));
    spec.spotDiameterDeg = o.spotDeg;
    spec.fieldHalfAngleDeg = o.fieldDeg;
    spec.fNumbers = o.fNumbers;
    spec.passes = o.passes;
    spec.pixels = o.pixels;
    spec.spread = o.gsf == "all"    ? GlareSpreadAt::All
                  : o.gsf == "none" ? GlareSpreadAt::None
                                    : GlareSpreadAt::Axis;
    spec.spreadRadiusMm = o.gsfRadiusMm;
    spec.spreadPixels = o.gsfPixels;
    spec.render.photonsPerPass = o.photons;
    spec.render.raysPerPixel = o.raysPerPixel;
    spec.render.seed = o.seed;
    const auto limit = limitThreads(o.threads);
    std::optional<ProgressReporter> reporter;
    if (!o.quiet)
        spec.progress = [&](size_t field, const std::string& run, int pass, int passes) {
            if (pass == 0) {
                reporter.emplace("glare: position " + std::to_string(field + 1) + ", " + run,
                                 static_cast<uint64_t>(passes), "passes");
                return;
            }
            reporter->update(static_cast<uint64_t>(pass));
            if (pass == passes) {
                reporter->finish();
                reporter.reset();
            }
        };
    const GlareResult result = runGlare(file, catalog, spec);

    WrittenFiles written;
    if (!dir.empty()) {
        written.beginRun(dir);
        std::filesystem::create_directories(dir);
        std::vector<std::pair<std::string, std::string>> files = {{"glare.md", result.markdown()},
                                                                  {"glare.csv", result.csv()},
                                                                  {"glare.json", result.json()}};
        bool spreads = false;
        for (const GlareField& f : result.fields) spreads = spreads || f.spread.has_value();
        if (spreads) files.push_back({"gsf.csv", result.spreadCsv()});
        for (const auto& [name, text] : files) {
            writeTextFile(dir / name, text);
            written.add(dir / name);
        }
        if (spreads) writePicture(drawChart(spreadChart(result)), dir / "gsf", 1600, written);
        if (result.fields.size() >= 2) {
            ChartSpec chart;
            chart.title = "Veiling glare index, black spot " +
                          std::to_string(o.spotDeg).substr(0, 4) + " deg";
            chart.xLabel = "field angle of the black spot (deg)";
            chart.yLabel = "VGI (%)";
            std::vector<double> apertures;
            for (const GlareField& f : result.fields)
                if (std::find(apertures.begin(), apertures.end(), f.fNumber) == apertures.end())
                    apertures.push_back(f.fNumber);
            auto fnum = [](double n) {
                std::ostringstream os;
                os << "f/" << std::setprecision(3) << n;
                return os.str();
            };
            for (double n : apertures) {
                const std::string tag = apertures.size() > 1 ? " " + fnum(n) : "";
                ChartSeries total{"VGI" + tag, {}, {}, {}},
                    specular{"specular (ghosts)" + tag, {}, {}, {}, true},
                    diffuse{"diffuse (scatter)" + tag, {}, {}, {}, true};
                for (const GlareField& f : result.fields) {
                    if (f.fNumber != n) continue;
                    const double angle = std::hypot(f.fieldDeg.x, f.fieldDeg.y);
                    for (auto [s, v] : {std::pair{&total, f.vgi}, std::pair{&specular, f.specular},
                                        std::pair{&diffuse, f.diffuse}}) {
                        s->x.push_back(angle);
                        s->y.push_back(100.0 * v.value);
                        s->yError.push_back(100.0 * v.error);
                    }
                }
                chart.series.push_back(total);
                if (apertures.size() == 1) {
                    chart.series.push_back(specular);
                    chart.series.push_back(diffuse);
                }
            }
            writePicture(drawChart(chart), dir / "glare", 1600, written);
        }
        written.finishRun();
    }
    printReport(result.json(), result.markdown(), written, o.json, o.quiet);
    return 0;
}

}  // namespace veil::cli
