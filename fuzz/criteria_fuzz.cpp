// libFuzzer target: a path criterion and a Zemax-style filter (analysis/criteria/criteria.h). A
// criterion that parses must print as text that parses back to the same criterion.
#include <cstdlib>
#include <iostream>

#include "analysis/criteria/criteria.h"
#include "fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text = veil::fuzz::asText(data, size);
    veil::fuzz::expectCleanRejection([&] {
        const veil::Criterion c = veil::parseCriterion(text);
        const std::string printed = veil::toString(c);
        const std::string again = veil::toString(veil::parseCriterion(printed));
        if (again != printed) {
            std::cerr << "criterion prints differently after a round trip:\n  " << printed
                      << "\n  " << again << "\n";
            std::abort();
        }
    });
    veil::fuzz::expectCleanRejection([&] { veil::parseZemaxFilter(text); });
    return 0;
}
