// libFuzzer target: a lens TOML file (lensdata/toml_reader.h).
#include "fuzz/fuzz_common.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/toml_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    veil::fuzz::expectCleanRejection([&] {
        veil::readTomlPrescriptionText(veil::fuzz::asText(data, size), "fuzz.toml",
                                       veil::GlassCatalog::builtIn());
    });
    return 0;
}
