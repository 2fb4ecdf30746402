// veil layout SCENE -o DIR: the y-z section of the lens with its mechanics, stop, detector
// and sources, as DIR/layout.svg and DIR/layout.png (DIR defaults to ./layout).
//
//   veil layout examples/scenes/double_gauss_50mm.toml -o out/dg      # out/dg/layout.svg, .png
//   veil layout lens.zmx --width-px 3000
//
// veil export SCENE -o scene.obj|scene.ply: every object as triangles for viewing in other
// tools (exact faces tessellated with --chord-tolerance, display only), grouped by object.

#include <algorithm>
#include <cctype>
#include <iostream>
#include <nlohmann/json.hpp>

#include "analysis/pictures/layout.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "geometry/mesh_io.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"

namespace veil::cli {

void addLayoutCommand(CLI::App& app, LayoutOptions& options) {
    CLI::App* sub =
        app.add_subcommand("layout", "2D section of lens, mechanics, stop, detector and sources");
    sub->add_option("scene", options.file, "scene or lens file (.toml or .zmx)")->required();
    addOutputFolder(sub, options.output, "layout");
    sub->add_option("--width-px", options.widthPx, "PNG width in pixels")
        ->check(CLI::Range(200, 20000))
        ->capture_default_str();
    sub->add_flag("--no-mechanics", options.noMechanics, "leave the [mechanics] section out");
    addReportFlags(sub, options.json, options.quiet);
}

int runLayout(const CommonOptions& common, const LayoutOptions& options) {
    const GlassCatalog catalog = loadCatalog(common);
    SceneOptions so;
    so.mechanics = !options.noMechanics;
    const std::unique_ptr<const PreparedScene> prepared =
        PreparedScene::build(readScene(common, options.file, catalog), catalog, so);
    const SceneGeometry& setup = prepared->geometry();
    reportSceneNotes(*prepared);
    veil::LayoutOptions lo;
    lo.title =
        setup.prescription.system.name.empty() ? options.file : setup.prescription.system.name;
    if (prepared->hasSources())
        lo.sources = layoutSources(prepared->transport().view.sources, setup.scene);
    lo.axisVerticesMm = layoutAxis(*setup.model);
    lo.detectors = layoutDetectors(setup.detectors);
    const Picture pic = drawLayout(setup.scene, lo);
    const std::filesystem::path dir = outputFolder(options.output, "layout", options.json);
    WrittenFiles written;
    if (!dir.empty()) {
        written.beginRun(dir);
        std::filesystem::create_directories(dir);
        writePicture(pic, dir / "layout", options.widthPx, written);
        written.finishRun();
    }
    if (options.json) {
        nlohmann::json j;
        j["scene"] = options.file;
        j["objects"] = nlohmann::json::array();
        for (const SceneObject& o : setup.scene.objects())
            j["objects"].push_back({{"name", o.name}, {"kind", std::string(toString(o.kind))}});
        j["files"] = written.json();
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::cout << setup.scene.objects().size() << " objects\n";
    if (!options.quiet) written.print(std::cout);
    return 0;
}

void addExportCommand(CLI::App& app, ExportOptions& options) {
    CLI::App* sub = app.add_subcommand("export", "the scene as OBJ or PLY triangles for viewing");
    sub->add_option("scene", options.file, "scene or lens file (.toml or .zmx)")->required();
    addOutputFile(sub, options.output, "OBJ or PLY file to write (folders created as needed)");
    sub->add_option("--chord-tolerance", options.chordToleranceMm,
                    "display tessellation of exact faces, mm")
        ->check(CLI::Range(1e-6, 10.0))
        ->capture_default_str();
    sub->add_flag("--no-mechanics", options.noMechanics, "leave the [mechanics] section out");
    addReportFlags(sub, options.json, options.quiet);
}

int runExport(const CommonOptions& common, const ExportOptions& options) {
    const std::filesystem::path out(options.output);
    std::string ext = out.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext != ".ply" && ext != ".obj")
        throw ParseError({"-o " + options.output, 0, 0}, "export writes .obj or .ply files");
    const GlassCatalog catalog = loadCatalog(common);
    SceneOptions so;
    so.mechanics = !options.noMechanics;
    const std::unique_ptr<const PreparedScene> prepared =
        PreparedScene::build(readScene(common, options.file, catalog), catalog, so);
    const SceneGeometry& setup = prepared->geometry();
    reportSceneNotes(*prepared);
    std::vector<int> objectOfTriangle;
    const TriangleMesh mesh = setup.scene.tessellate(options.chordToleranceMm, &objectOfTriangle);
    std::vector<std::string> names;
    for (const SceneObject& o : setup.scene.objects()) names.push_back(o.name);
    if (!out.parent_path().empty()) std::filesystem::create_directories(out.parent_path());
    if (ext == ".ply")
        writeMeshPly(out, mesh, objectOfTriangle);
    else
        writeMeshObj(out, mesh, objectOfTriangle, names);
    WrittenFiles written;
    written.add(out);
    if (options.json) {
        nlohmann::json j;
        j["scene"] = options.file;
        j["triangles"] = mesh.triangles.size();
        j["objects"] = names;
        j["files"] = written.json();
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::cout << mesh.triangles.size() << " triangles, " << names.size() << " objects\n";
    if (!options.quiet) written.print(std::cout);
    return 0;
}

}  // namespace veil::cli
