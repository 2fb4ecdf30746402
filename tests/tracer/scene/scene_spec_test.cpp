// Scene assembly builds the sequential model once: the scene file's model (of the sized
// prescription) is the one the scene, the sources and the ghost tracer use.

#include "tracer/scene/scene_spec.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "lensdata/glass_catalog.h"
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
