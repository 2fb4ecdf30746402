// The double Gauss of US 2,673,491 read from a CODE V .seq file has the patent's first-order
// data (EFL 1.0 and back focus 0.71436 at f = 1, here x50) and the same as the TOML example.

#include <gtest/gtest.h>

#include "analysis/first_order.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene_setup.h"
#include "tracer/sequential_model.h"

namespace veil {
namespace {

TEST(CodeVImport, DoubleGaussHasThePatentsFirstOrderData) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneFile seq =
        readSceneFile(VEIL_SOURCE_DIR "/tests/data/codev/double_gauss_50mm.seq", catalog);
    const SceneFile toml =
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

}  // namespace
}  // namespace veil
