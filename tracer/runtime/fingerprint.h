#pragma once
// FNV-1a, 64 bit, over a text: the stable fingerprint that tells whether a checkpoint, a
// sweep's cached variant or a resumed run belongs to the run at hand (the text is what
// determines the run's numbers, printed with full precision).

#include <cstdint>
#include <string_view>

namespace veil {

inline uint64_t fnv1a64(std::string_view text) {
    uint64_t h = 1469598103934665603ull;
    for (const unsigned char c : text) {
        h ^= c;
        h *= 1099511628211ull;
    }
    return h;
}

}  // namespace veil
