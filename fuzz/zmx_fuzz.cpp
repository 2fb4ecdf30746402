// libFuzzer target: a Zemax .zmx file, any encoding (lensdata/zmx_reader.h).
#include "fuzz/fuzz_common.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/zmx_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    veil::fuzz::expectCleanRejection([&] {
        veil::readZmxText(veil::fuzz::asText(data, size), "fuzz.zmx",
                          veil::GlassCatalog::builtIn());
    });
    return 0;
}
