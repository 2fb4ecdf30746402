// The double Gauss of US 2,673,491 read from a CODE V .seq file has the patent's first-order
// data (EFL 1.0 and back focus 0.71436 at f = 1, here x50) and the same as the TOML example.

#include <gtest/gtest.h>

#include <cmath>

#include "analysis/lens/first_order.h"
#include "lensdata/codev_reader.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {
namespace {

TEST(CodeVImport, DoubleGaussHasThePatentsFirstOrderData) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec seq =
        readSceneFile(VEIL_SOURCE_DIR "/tests/data/codev/double_gauss_50mm.seq", catalog);
    const SceneSpec toml =
        readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/double_gauss_50mm.toml", catalog);
    const FirstOrderData a = computeFirstOrder(*seq.model, seq.model->primaryWavelength());
    const FirstOrderData b = computeFirstOrder(*toml.model, toml.model->primaryWavelength());
    // The patent: f = 1.0, p0' = 0.71436 (x50: 50 mm, 35.718 mm); veil's glasses are the
    // patent's nd / v, so the match is to the table's rounding.
    EXPECT_NEAR(a.eflMm, 50.0, 0.01);
    EXPECT_NEAR(a.bflMm, 0.71436 * 50.0, 0.01);
    EXPECT_NEAR(a.eflMm, b.eflMm, 1e-9);
    EXPECT_NEAR(a.bflMm, b.bflMm, 1e-9);
    EXPECT_NEAR(a.entrancePupilDiameterMm, 25.0, 1e-12);
}

// A plastic singlet whose glass is the file's own (a PRV private catalog: 20 indices from
// 400 to 1600 nm), from ray-optics' tests (tests/data/README.md). Truth: the thick-lens
// formula with n_d from SciPy's natural spline through the table over 1 / lambda^2.
TEST(CodeVImport, PrivateGlassSingletHasTheThickLensFocalLength) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec seq =
        readSceneFile(VEIL_SOURCE_DIR "/tests/data/codev/CODV_65988_noDOE.seq", catalog);
    const FirstOrderData f = computeFirstOrder(*seq.model, seq.model->primaryWavelength());
    const double n = 1.5311617964888755, r1 = 9.93, r2 = -48.3, t = 3.7;
    const double power = (n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * t / (n * r1 * r2));
    EXPECT_NEAR(f.eflMm, 1.0 / power, 1e-9);
}

// A singlet decentered with its stop by YDE 0.35 on both faces (DAR: each returns, so the
// image plane stays on the axis) images every field 0.35 mm further along y than the
// centred singlet, to rounding.
TEST(CodeVImport, DarDecenteredSingletMovesItsImageByTheDecenter) {
    auto model = [](const std::string& decenter) {
        const std::string text =
            "RDM;LEN\nEPD 10\nWL 587.56\nYAN 0 3 -4\nSO 0 1e11\n"
            "S 0 15\nS 60 5 1.6:0\n  STO\n" +
            decenter + "S -250 80\n" + decenter + "SI 0 0\nGO\n";
        const Prescription p = readCodeVText(text, "dar.seq", GlassCatalog::builtIn());
        return SequentialModel::build(p, GlassCatalog::builtIn());
    };
    const SequentialModel nominal = model(""), moved = model("  YDE 0.35; DAR\n");
    EXPECT_FALSE(moved.coaxial());
    const RayAimer an(nominal, AimMode::Real), am(moved, AimMode::Real);
    for (int f = 0; f < 3; ++f)
        for (const double py : {0.0, 0.7}) {
            const Field& field = nominal.prescription().system.fields[f];
            const SequentialRayResult a =
                traceSequential(nominal, 0, an.aim(field, 0.0, py, 0).ray);
            const SequentialRayResult b = traceSequential(moved, 0, am.aim(field, 0.0, py, 0).ray);
            ASSERT_TRUE(a.ok() && b.ok());
            const Vec3 qa = nominal.localPoint(nominal.imageIndex(), a.ray.origin);
            const Vec3 qb = moved.localPoint(moved.imageIndex(), b.ray.origin);
            EXPECT_NEAR(qb.y, qa.y + 0.35, 1e-10);
            EXPECT_NEAR(qb.x, qa.x, 1e-10);
        }
}

// A paraboloid (R = -200, K -1) and a flat mirror 40 mm in front of it with ADE 45 and BEN:
// the fold of lens design programs. The focus is the mirror image of (0, 0, -100) in the fold
// plane, (0, 60, -40) (the same fold as CoordinateBreak.FoldMirrorPutsTheImageWhereTheFolded-
// FocusIs, written in CODE V).
TEST(CodeVImport, BentMirrorFoldsTheFocus) {
    const std::string text =
        "RDM;LEN\nEPD 40\nWL 587.56\nYAN 0\nSO 0 1e11\n"
        "S -200 -40 REFL\n  STO\n  K -1\nS 0 60 REFL\n  ADE 45; BEN\nSI 0 0\nGO\n";
    const Prescription p = readCodeVText(text, "fold.seq", GlassCatalog::builtIn());
    const SequentialModel m = SequentialModel::build(p, GlassCatalog::builtIn());
    const Vec3 v = m.surface(m.imageIndex()).frame.translation;
    EXPECT_NEAR(v.x, 0.0, 1e-12);
    EXPECT_NEAR(v.y, 60.0, 1e-12);
    EXPECT_NEAR(v.z, -40.0, 1e-12);
    for (double y : {-15.0, 4.0, 18.0}) {
        const SequentialRayResult r =
            traceSequential(m, 0, Ray{Vec3(0.0, y, -10.0), Vec3(0.0, 0.0, 1.0)});
        ASSERT_TRUE(r.ok()) << r;
        EXPECT_NEAR(glm::length(r.ray.origin - Vec3(0.0, 60.0, -40.0)), 0.0, 1e-11);
    }
}

// REV undoes a basic decenter of the same values: a dummy shifted and tilted (YDE, ADE, BDE,
// ZDE), then a dummy with the same values and REV, then a singlet: the frames after REV are
// the centred ones again, while the basic decenter alone leaves the axis turned.
TEST(CodeVImport, ReverseDecenterRestoresTheAxis) {
    auto model = [](const std::string& front, const std::string& back) {
        const std::string text =
            "RDM;LEN\nEPD 10\nWL 587.56\nYAN 0 3\nSO 0 1e11\n"
            "S 0 15\n  STO\nS 0 0\n" +
            front + "S 0 0\n" + back + "S 60 5 1.6:0\nS -250 80\nSI 0 0\nGO\n";
        const Prescription p = readCodeVText(text, "rev.seq", GlassCatalog::builtIn());
        for (const ImportNote& n : p.report)
            EXPECT_NE(n.severity, ImportNote::Severity::Error) << n;
        return SequentialModel::build(p, GlassCatalog::builtIn());
    };
    const std::string values = "YDE 0.4; ADE 2.5; BDE -1.5; ZDE 0.3\n";
    const SequentialModel reversed = model("  " + values, "  REV; " + values);
    EXPECT_FALSE(reversed.coaxial());
    // The front face's frame is turned; the last faces' frames are the centred ones, shifted
    // along z by the dummy's thickness only.
    const int image = reversed.imageIndex();
    const Frame& f = reversed.surface(image).frame;
    EXPECT_NEAR(f.translation.x, 0.0, 1e-12);
    EXPECT_NEAR(f.translation.y, 0.0, 1e-12);
    EXPECT_NEAR(f.translation.z, 15.0 + 5.0 + 80.0, 1e-12);
    const Vec3 z = reversed.surface(image).toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    EXPECT_NEAR(z.x, 0.0, 1e-15);
    EXPECT_NEAR(z.y, 0.0, 1e-15);
    // A basic decenter without REV leaves the axis turned.
    const SequentialModel basic = model("  " + values, "");
    const Vec3 zb = basic.surface(basic.imageIndex()).toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    EXPECT_GT(std::hypot(zb.x, zb.y), 0.03);
}

}  // namespace
}  // namespace veil
