// Scene assembly builds the sequential model once: the scene file's model (of the sized
// prescription) is the one the scene, the sources and the ghost tracer use.

#include "tracer/scene/scene_spec.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "geometry/lens_solid.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/surfaces/property_table.h"

namespace veil {
namespace {

void expectModelOf(const SequentialModel& model, const Prescription& p) {
    const Prescription& m = model.prescription();
    ASSERT_EQ(m.surfaces.size(), p.surfaces.size());
    for (size_t i = 0; i < p.surfaces.size(); ++i) {
        EXPECT_EQ(m.surfaces[i].clearSemiDiameterMm, p.surfaces[i].clearSemiDiameterMm) << i;
        EXPECT_EQ(m.surfaces[i].thicknessMm, p.surfaces[i].thicknessMm) << i;
    }
}

TEST(SceneGeometry, OneSequentialModelServesTheFileAndTheScene) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    // The 360 mm lens leaves semi-diameters to be traced: the model is of the sized lens.
    const SceneSpec file =
        readSceneFile(VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml", catalog);
    ASSERT_TRUE(file.model);
    bool automatic = false;
    for (const Surface& s : file.prescription.surfaces) automatic |= s.semiDiameterAutomatic;
    EXPECT_TRUE(automatic);
    expectModelOf(*file.model, file.prescription);
    const SceneGeometry setup = buildSceneGeometry(file, catalog);
    EXPECT_EQ(setup.model.get(), file.model.get());
}

TEST(SceneGeometry, HandMadeSceneFileGetsAModel) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    SceneSpec file = readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/singlet.toml", catalog);
    file.model.reset();
    const SceneGeometry setup = buildSceneGeometry(file, catalog);
    ASSERT_TRUE(setup.model);
    expectModelOf(*setup.model, file.prescription);
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

TEST(PreparedScene, OneOwnerForTheSceneAndTheTransport) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const auto prepared =
        PreparedScene::read(VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml", catalog);
    ASSERT_TRUE(prepared->hasSources());
    const SceneTransport& t = prepared->transport();
    // The transport points into the same (pinned) object, and the model is the file's.
    EXPECT_EQ(t.view.scene, &prepared->scene());
    EXPECT_EQ(t.view.media, t.media.get());
    EXPECT_EQ(&prepared->model(), prepared->spec().model.get());
    EXPECT_EQ(t.view.propertyOfObject.size(), prepared->scene().objects().size());
    EXPECT_EQ(t.images.size(), prepared->geometry().detectors.size());
}

TEST(PreparedScene, SceneWithoutSourcesHasNoTransportAndSaysWhichFile) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::string path = VEIL_SOURCE_DIR "/examples/scenes/double_gauss_50mm.toml";
    const auto prepared = PreparedScene::read(path, catalog);
    EXPECT_FALSE(prepared->hasSources());
    EXPECT_GT(prepared->scene().objects().size(), 10u);  // built all the same (layout, export)
    try {
        prepared->transport();
        FAIL() << "expected a ModelError";
    } catch (const ModelError& e) {
        EXPECT_EQ(e.object(), path);
        EXPECT_NE(std::string(e.what()).find("no [[source]]"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// A misspelt key in a section that then fails its own check is reported first: the typo is
// the cause, the missing value its consequence. Sections not read yet are not reported.
TEST(SceneSpec, MisspeltKeyIsReportedBeforeTheErrorItCauses) {
    const std::string path = ::testing::TempDir() + "veil_typo_scene.toml";
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fprintf(f,
            "lens = \"%s/examples/lenses/singlet.toml\"\n"
            "[[source]]\nname = \"lamp\"\nkind = \"point\"\npositon_mm = [0.0, 1.0, -100.0]\n"
            "[detector]\nname = \"det\"\n",
            VEIL_SOURCE_DIR);
    fclose(f);
    try {
        readSceneFile(path, GlassCatalog::builtIn());
        FAIL() << "expected a ParseError";
    } catch (const ParseError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find(path + ":5:1"), std::string::npos) << what;
        EXPECT_NE(what.find("unknown key 'positon_mm'"), std::string::npos) << what;
        EXPECT_NE(what.find("did you mean 'position_mm'?"), std::string::npos) << what;
    }
}

// Roughness past the smooth-surface limit at one of the lens's wavelengths is refused when
// the scene is read, naming the property and the wavelength; smoother roughness is read.
TEST(SceneSpec, RoughnessPastTheSmoothSurfaceLimitIsRefused) {
    auto write = [](const std::string& path, double sigmaNm) {
        FILE* f = fopen(path.c_str(), "w");
        ASSERT_TRUE(f);
        fprintf(f,
                "lens = \"%s/examples/lenses/singlet.toml\"\n"
                "[properties.rough]\nspecular = \"fresnel\"\n"
                "scatter = { model = \"k_correlation\", sigma_nm = %g, b_um = 2, c = 3, "
                "reflectance = 0.04, transmission = true }\n"
                "[[assign]]\nobjects = \"s*\"\nproperty = \"rough\"\n",
                VEIL_SOURCE_DIR, sigmaNm);
        fclose(f);
    };
    const std::string path = ::testing::TempDir() + "veil_rough_scene.toml";
    write(path, 2.0);
    EXPECT_NO_THROW(readSceneFile(path, GlassCatalog::builtIn()));
    write(path, 200.0);
    try {
        readSceneFile(path, GlassCatalog::builtIn());
        FAIL() << "expected a ModelError";
    } catch (const ModelError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("rough"), std::string::npos) << what;
        EXPECT_NE(what.find("486.133 nm"), std::string::npos) << what;
        EXPECT_NE(what.find("too rough for the smooth-surface"), std::string::npos) << what;
    }
}

// Material libraries: their [properties] tables come before the scene's (which replace
// them), .bsdf paths inside are relative to the library, and a bad library is an error at
// its entry or in the library itself.
TEST(SceneSpec, MaterialLibrariesAreReadBeforeTheScenesProperties) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(::testing::TempDir()) / "veil_materials";
    fs::remove_all(dir);
    fs::create_directories(dir / "lib");
    auto write = [](const fs::path& p, const std::string& text) {
        FILE* f = fopen(p.c_str(), "w");
        ASSERT_TRUE(f);
        fputs(text.c_str(), f);
        fclose(f);
    };
    const std::string lens =
        std::string("lens = \"") + VEIL_SOURCE_DIR + "/examples/lenses/singlet.toml\"\n";
    write(dir / "lib" / "mats.toml",
          "[properties.paint]\nscatter = { model = \"lambertian\", reflectance = 0.04 }\n"
          "[properties.shared]\nscatter = { model = \"lambertian\", reflectance = 0.3 }\n");
    write(dir / "scene.toml", lens +
                                  "materials = \"lib/mats.toml\"\n"
                                  "[properties.shared]\nscatter = { model = \"lambertian\", "
                                  "reflectance = 0.1 }\n");
    const SceneSpec f = readSceneFile(dir / "scene.toml", GlassCatalog::builtIn());
    const PropertyTable& t = f.properties;
    ASSERT_GE(t.find("paint"), 0);
    EXPECT_EQ(std::get<LambertianScatter>(t.property(t.find("paint")).scatter()).reflectance, 0.04);
    EXPECT_EQ(std::get<LambertianScatter>(t.property(t.find("shared")).scatter()).reflectance, 0.1);

    auto errorOf = [&](const std::string& scene) {
        write(dir / "bad.toml", lens + scene);
        try {
            readSceneFile(dir / "bad.toml", GlassCatalog::builtIn());
        } catch (const ParseError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    std::string e = errorOf("materials = [\"lib/none.toml\"]\n");
    EXPECT_NE(e.find("bad.toml:2:14"), std::string::npos) << e;
    EXPECT_NE(e.find("does not exist"), std::string::npos) << e;
    write(dir / "lib" / "empty.toml", "# nothing\n");
    e = errorOf("materials = \"lib/empty.toml\"\n");
    EXPECT_NE(e.find("has no [properties.NAME] tables"), std::string::npos) << e;
    write(dir / "lib" / "extra.toml",
          "[properties.p]\nscatter = { model = \"lambertian\", reflectance = 0.04 }\n"
          "[[source]]\nname = \"x\"\n");
    e = errorOf("materials = \"lib/extra.toml\"\n");
    EXPECT_NE(e.find("extra.toml:3"), std::string::npos) << e;
    write(dir / "lib" / "typo.toml",
          "[properties.p]\nscatter = { model = \"lambertian\", reflectanse = 0.04 }\n");
    e = errorOf("materials = \"lib/typo.toml\"\n");
    EXPECT_NE(e.find("typo.toml:2"), std::string::npos) << e;
    EXPECT_NE(e.find("reflectanse"), std::string::npos) << e;
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// A CODE V double Gauss (tests/data/README.md) whose full field is vignetted 40 % top and
// bottom (VUY, VLY). Its automatic semi-diameters are sized by the vignetted beam, as CODE V
// sizes them, and it builds as written. The full beam would need L2 wider than its faces
// allow: without the factors the lens cannot be built, and the error says what fits.
TEST(SceneSpec, VignettingFactorsSizeTheLens) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::filesystem::path file = VEIL_SOURCE_DIR "/tests/data/codev/ag_dblgauss.seq";
    const SceneSpec asWritten = readSceneFile(file, catalog);
    EXPECT_TRUE(asWritten.sizeChanges.empty());
    EXPECT_FALSE(asWritten.sizeError);
    EXPECT_NO_THROW(buildSceneGeometry(asWritten, catalog));

    const std::filesystem::path copy =
        std::filesystem::temp_directory_path() / "veil_fit_unvignetted.seq";
    {
        std::ifstream in(file);
        std::ofstream out(copy);
        std::string line;
        while (std::getline(in, line))
            if (line.rfind("VUY", 0) != 0 && line.rfind("VLY", 0) != 0) out << line << "\n";
    }
    const SceneSpec full = readSceneFile(copy, catalog);
    std::filesystem::remove(copy);
    ASSERT_TRUE(full.sizeError);
    const std::string what = full.sizeError->what();
    EXPECT_EQ(full.sizeError->object(), "L2.front");
    EXPECT_NE(what.find("its faces L2.front and L2.back cross inside the light"), std::string::npos)
        << what;
    EXPECT_NE(what.find("the largest semi-diameter that fits is 28."), std::string::npos) << what;
    // First-order work goes on; the scene build stops with that error.
    EXPECT_TRUE(full.model);
    try {
        buildSceneGeometry(full, catalog);
        FAIL() << "built";
    } catch (const ModelError& e) {
        EXPECT_EQ(std::string(e.what()), what);
    }
}

// A CODE V singlet (tests/data/README.md) whose semi-diameters leave a negative edge is
// fitted: the element shrinks to an edge of a quarter of its centre thickness, reported.
TEST(SceneSpec, ALensWhoseSizesDoNotBuildIsFittedAndSaysSo) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec spec =
        readSceneFile(VEIL_SOURCE_DIR "/tests/data/codev/lens_reflection_test.seq", catalog);
    ASSERT_FALSE(spec.sizeError) << spec.sizeError->what();
    ASSERT_EQ(spec.sizeChanges.size(), 1u);
    const LensSizeChange& c = spec.sizeChanges[0];
    EXPECT_EQ(c.element, "L1");
    EXPECT_EQ(c.radiusBeforeMm, 0.875);
    EXPECT_LT(c.radiusAfterMm, 0.875);
    EXPECT_NE(c.reason.find("edge thickness -0.033"), std::string::npos) << c.reason;
    int warned = 0;
    for (const ImportNote& n : spec.prescription.report)
        if (n.message.rfind("sized to fit: L1: ", 0) == 0) {
            ++warned;
            EXPECT_EQ(n.severity, ImportNote::Severity::Warning);
        }
    EXPECT_EQ(warned, 1);
    // The model is of the fitted sizes, and the scene builds from them.
    expectModelOf(*spec.model, spec.prescription);
    const std::vector<LensSolid> solids = lensSolids(spec.prescription);
    const double centre =
        solids[0].direction * (solids[0].back.vertexZMm - solids[0].front.vertexZMm);
    EXPECT_NEAR(solids[0].direction * (solids[0].back.rimZMm - solids[0].front.rimZMm),
                std::min(0.5, 0.25 * centre), 1e-9);
    EXPECT_NO_THROW(buildSceneGeometry(spec, catalog));
}

// A lens whose front sphere is narrower than the beam (ray-optics' landscape_lens.seq: its
// numbers are curvatures, but it has no RDM N, so CODE V and veil read them as radii): no
// ray of the bundle gets through, and the sizing says where they failed and what to check,
// before the scene's own error about the missing size.
TEST(SceneSpec, ASurfaceNoRayReachesIsSaidWithWhereTheRaysFailed) {
    const std::filesystem::path seq =
        std::filesystem::path(::testing::TempDir()) / "veil_landscape.seq";
    std::ofstream(seq) << "tit 'Landscape lens'\ndim m\nso 0. 1.0e+10\ns 0. 1.664\nsto\n"
                          "s -0.2 0.22 NBK7_SCHOTT\ns -0.387040626 10.150245\nsi 0 0\n"
                          "epd 1.0\nwl 650 550 450\nref 2\nyim 0 3\n";
    const SceneSpec spec = readSceneFile(seq, GlassCatalog::builtIn());
    bool said = false;
    for (const ImportNote& n : spec.prescription.report)
        if (n.message.find("no ray of the file's beam reaches L1.front off the axis") !=
            std::string::npos) {
            said = true;
            EXPECT_EQ(n.severity, ImportNote::Severity::Warning);
            EXPECT_NE(n.message.find("miss L1.front (radius -0.2 mm: a sphere narrower than the "
                                     "beam?)"),
                      std::string::npos)
                << n.message;
            EXPECT_EQ(n.loc.line, 6) << n.message;
        }
    EXPECT_TRUE(said);
    std::filesystem::remove(seq);
}

// A Zemax lens whose aperture floats by a stop without a size (DeepLens' ef35mm_f2.0.zmx)
// says how to give the aperture, and the way it names works: --set system.aperture.f_number
// replaces the file's kind of aperture (the aperture is one of them).
TEST(SceneSpec, AnApertureSetReplacesTheFilesKindOfAperture) {
    const std::filesystem::path zmx =
        std::filesystem::path(::testing::TempDir()) / "veil_float_no_stop.zmx";
    std::ofstream(zmx) << "FLOA\nWAVM 1 0.5876 1\nYFLN 0\nSURF 0\n DISZ INFINITY\n"
                          "SURF 1\n STOP\n DISZ 5\nSURF 2\n CURV 0.02\n DISZ 3\n"
                          " GLAS N-BK7 0 0 1.5168 64.17\n DIAM 8 1\nSURF 3\n CURV -0.02\n"
                          " DISZ 45\n DIAM 8 1\nSURF 4\n";
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    try {
        readSceneFile(zmx, catalog);
        ADD_FAILURE() << "a floating aperture without a stop size was taken";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("--set system.aperture.f_number="), std::string::npos)
            << e.what();
    }
    const SceneSpec f = readSceneFile(zmx, catalog, {{"system.aperture.f_number", "4", "--set"}});
    EXPECT_EQ(f.prescription.system.aperture.kind, SystemAperture::Kind::ImageSpaceFNumber);
    EXPECT_EQ(f.prescription.system.aperture.value, 4.0);
    std::filesystem::remove(zmx);
}

// A source kind in the wrong case, a misspelt kind and a misspelt lens key are reported as
// what they are, not as the unknown keys or missing tables they lead to.
TEST(SceneSpec, MisspeltKindsAndLensKeysSayWhatWasMeant) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::filesystem::path dir = std::filesystem::temp_directory_path();
    auto errorOf = [&](const std::string& text) -> std::string {
        const std::filesystem::path path = dir / "veil_misspelt.toml";
        std::ofstream(path) << text;
        try {
            readSceneFile(path, catalog);
        } catch (const ParseError& e) {
            return e.what();
        }
        return "";
    };
    const std::string lens = "lens = \"" VEIL_SOURCE_DIR "/examples/lenses/singlet.toml\"\n";
    const std::string source = "[[source]]\nkind = \"Sun\"\nfield_deg = [0.0, 1.0]\n";
    std::string e = errorOf(lens + source);
    EXPECT_NE(e.find("3:8: unknown source kind 'Sun' (kinds are lower case: 'sun')"),
              std::string::npos)
        << e;
    e = errorOf(lens + "[[source]]\nkind = \"colimated\"\nfield_deg = [0.0, 1.0]\n");
    EXPECT_NE(e.find("unknown source kind 'colimated' (did you mean 'collimated'?)"),
              std::string::npos)
        << e;
    e = errorOf("lense = \"singlet.toml\"\n" + source);
    EXPECT_NE(e.find("1:9: unknown key 'lense' (did you mean 'lens'?)"), std::string::npos) << e;
    // A bad value is reported as itself, not as the next key, which its reader had not asked
    // for yet ("unknown key 'pixels'", "unknown key 'margin_mm'").
    e = errorOf(lens +
                "[detector]\nname = \"d\"\nobject = \"image\"\nsize_mm = [0, 24]\n"
                "pixels = [64, 64]\n");
    EXPECT_NE(e.find(":5:"), std::string::npos) << e;
    EXPECT_NE(e.find("size_mm"), std::string::npos) << e;
    EXPECT_EQ(e.find("unknown key"), std::string::npos) << e;
    e = errorOf(lens + "[[source]]\nkind = \"collimated\"\nfield_deg = 90\nmargin_mm = 1\n");
    EXPECT_NE(e.find("field_deg"), std::string::npos) << e;
    EXPECT_NE(e.find("strictly between -90 and 90"), std::string::npos) << e;
    EXPECT_EQ(e.find("unknown key"), std::string::npos) << e;
    std::filesystem::remove(dir / "veil_misspelt.toml");
}

// A coating name from a lens file that no optical property defines is a warning naming it,
// and its faces are left at the default, instead of stopping the build.
TEST(SceneSpec, AnUnknownCoatingOfALensFileLeavesItsFacesUncoated) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::filesystem::path zmx =
        std::filesystem::temp_directory_path() / "veil_unknown_coat.zmx";
    {
        std::ofstream out(zmx);
        out << "NAME c\nENPD 10\nFTYP 0 0 1 1\nYFLN 0\nWAVM 1 0.55 1\nSURF 0\n DISZ INFINITY\n"
               "SURF 1\n STOP\n CURV 0.02\n DISZ 3\n GLAS N-BK7 0 0 1.5168 64.17\n COAT THORA\n"
               " DIAM 6 1\nSURF 2\n CURV -0.02\n DISZ 45\n COAT THORA\n DIAM 6 1\nSURF 3\n";
    }
    const std::filesystem::path toml =
        std::filesystem::temp_directory_path() / "veil_unknown_coat.toml";
    {
        std::ofstream out(toml);
        out << "lens = \"veil_unknown_coat.zmx\"\n[[source]]\nname = \"sun\"\nkind = \"sun\"\n"
               "field_deg = [0.0, 1.0]\n";
    }
    const SceneSpec spec = readSceneFile(toml, catalog);
    EXPECT_TRUE(spec.prescription.surfaces[1].coating.empty());
    EXPECT_TRUE(spec.prescription.surfaces[2].coating.empty());
    int warnings = 0;
    for (const ImportNote& n : spec.prescription.report)
        if (n.message.find("coating 'THORA'") != std::string::npos) {
            ++warnings;
            EXPECT_EQ(n.severity, ImportNote::Severity::Warning);
            EXPECT_NE(n.message.find("L1.front, L1.back are left uncoated"), std::string::npos)
                << n.message;
            EXPECT_EQ(n.loc.line, 8);  // SURF 1
        }
    EXPECT_EQ(warnings, 1);
    const auto prepared = PreparedScene::build(spec, catalog);
    EXPECT_TRUE(prepared->hasSources());
    EXPECT_EQ(readSceneFile(zmx, catalog).prescription.report.size(),
              spec.prescription.report.size());
    std::filesystem::remove(zmx);
    std::filesystem::remove(toml);
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// A Zemax file sized for one on-axis field: its automatic image semi-diameter is the spot's,
// nanometres. The sensor gets a tenth of the last lens surface instead, with a warning, and
// an image on the last face itself moves behind it, where the light leaving the face can
// reach it.
TEST(SceneGeometry, ASpotSizedImageMakesAUsableSensorSaid) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::filesystem::path zmx =
        std::filesystem::temp_directory_path() / "veil_spot_image.zmx";
    {
        std::ofstream out(zmx);
        out << "NAME s\nENPD 10\nFTYP 0 0 1 1\nYFLN 0\nWAVM 1 0.55 1\nSURF 0\n DISZ INFINITY\n"
               "SURF 1\n STOP\n CURV 0.02\n DISZ 3\n GLAS N-BK7 0 0 1.5168 64.17\n DIAM 6 0\n"
               "SURF 2\n CURV -0.02\n DISZ 0\n DIAM 6 0\nSURF 3\n DIAM 1e-8 0\n";
    }
    const SceneSpec spec = readSceneFile(zmx, catalog);
    std::filesystem::remove(zmx);
    const SceneGeometry g = buildSceneGeometry(spec, catalog);
    const SceneObject* sensor = g.scene.find("sensor");
    ASSERT_NE(sensor, nullptr);
    const auto& patch = std::get<SurfacePatch>(std::get<FaceGeometry>(sensor->geometry));
    EXPECT_NEAR(std::get<CircularAperture>(patch.aperture).radiusMm, 0.6, 1e-12);
    bool warned = false, moved = false;
    for (const ImportNote& n : g.notes) {
        warned |= n.severity == ImportNote::Severity::Warning &&
                  n.message.find("the sensor is 0.6 mm in radius") != std::string::npos;
        moved |= n.message.find("the image lies on L1.back itself") != std::string::npos;
    }
    EXPECT_TRUE(warned);
    EXPECT_TRUE(moved);
    EXPECT_NEAR(sensor->frame.translation.z, 3.0 + 1e-3, 1e-12);
}

}  // namespace
}  // namespace veil
