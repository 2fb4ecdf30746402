// libFuzzer target: a glass catalog, AGF, any encoding (lensdata/agf_reader.h).
#include "fuzz/fuzz_common.h"
#include "lensdata/agf_reader.h"
#include "lensdata/text_decoding.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    veil::fuzz::expectCleanRejection([&] {
        const std::string text = veil::decodeText(veil::fuzz::asText(data, size), "fuzz.agf");
        veil::parseAgf(text, "fuzz.agf", "FUZZ");
    });
    return 0;
}
