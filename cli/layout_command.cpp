// veil layout SCENE -o layout.svg: the y-z section of the lens with its mechanics, stop and
// detector, as SVG and PNG (the PNG beside the SVG unless --png names it).
//
//   veil layout examples/scenes/double_gauss_50mm.toml -o dg.svg          # dg.svg, dg.png
//   veil layout lens.zmx -o lens.svg --png preview.png --width-px 3000
//
// veil export SCENE -o scene.obj|scene.ply: every object as triangles for viewing in other
// tools (exact faces tessellated with --chord-tolerance, display only), grouped by object.

#include <iostream>

#include "analysis/layout.h"
#include "cli/commands.h"
#include "geometry/mesh_io.h"
#include "tracer/prepared_scene.h"

namespace veil::cli {

void addLayoutCommand(CLI::App& app, LayoutOptions& options) {
    CLI::App* sub =
        app.add_subcommand("layout", "2D section of lens, mechanics, stop and detector");
    sub->add_option("scene", options.file, "scene or lens file (.toml or .zmx)")->required();
    sub->add_option("-o,--output", options.output, "SVG file to write")->capture_default_str();
    sub->add_option("--png", options.png, "PNG file (default: the SVG name with .png)");
    sub->add_option("--width-px", options.widthPx, "PNG width in pixels")
        ->check(CLI::Range(200, 20000))
        ->capture_default_str();
    sub->add_flag("--no-mechanics", options.noMechanics, "leave the [mechanics] section out");
}

int runLayout(const CommonOptions& common, const LayoutOptions& options) {
    const GlassCatalog catalog = loadCatalog(common);
    SceneOptions so;
    so.mechanics = !options.noMechanics;
    const std::unique_ptr<const PreparedScene> prepared =
        PreparedScene::read(options.file, catalog, so);
    const SceneSetup& setup = prepared->setup();
    veil::LayoutOptions lo;
    lo.title =
        setup.prescription.system.name.empty() ? options.file : setup.prescription.system.name;
    const Picture pic = drawLayout(setup.scene, lo);
    std::filesystem::path png = options.png;
    if (png.empty()) png = std::filesystem::path(options.output).replace_extension(".png");
    pic.writeSvg(options.output);
    pic.writePng(png, options.widthPx);
    std::cout << "wrote " << options.output << " and " << png.string() << " ("
              << setup.scene.objects().size() << " objects)\n";
    reportSceneNotes(setup);
    return 0;
}

void addExportCommand(CLI::App& app, ExportOptions& options) {
    CLI::App* sub = app.add_subcommand("export", "the scene as OBJ or PLY triangles for viewing");
    sub->add_option("scene", options.file, "scene or lens file (.toml or .zmx)")->required();
    sub->add_option("-o,--output", options.output, "OBJ or PLY file to write")
        ->capture_default_str();
    sub->add_option("--chord-tolerance", options.chordToleranceMm,
                    "display tessellation of exact faces, mm")
        ->check(CLI::Range(1e-6, 10.0))
        ->capture_default_str();
    sub->add_flag("--no-mechanics", options.noMechanics, "leave the [mechanics] section out");
}

int runExport(const CommonOptions& common, const ExportOptions& options) {
    const GlassCatalog catalog = loadCatalog(common);
    SceneOptions so;
    so.mechanics = !options.noMechanics;
    const std::unique_ptr<const PreparedScene> prepared =
        PreparedScene::read(options.file, catalog, so);
    const SceneSetup& setup = prepared->setup();
    std::vector<int> objectOfTriangle;
    const TriangleMesh mesh = setup.scene.tessellate(options.chordToleranceMm, &objectOfTriangle);
    std::vector<std::string> names;
    for (const SceneObject& o : setup.scene.objects()) names.push_back(o.name);
    const std::string ext = std::filesystem::path(options.output).extension().string();
    if (ext == ".ply" || ext == ".PLY")
        writeMeshPly(options.output, mesh, objectOfTriangle);
    else if (ext == ".obj" || ext == ".OBJ")
        writeMeshObj(options.output, mesh, objectOfTriangle, names);
    else
        throw ParseError({options.output, 0, 0}, "export writes .obj or .ply files");
    std::cout << "wrote " << options.output << " (" << mesh.triangles.size() << " triangles, "
              << names.size() << " objects)\n";
    return 0;
}

}  // namespace veil::cli
