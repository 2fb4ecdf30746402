#pragma once
// Checks on the text veil writes for users.

#include <cctype>
#include <string>

namespace veil_test {

// An inf or nan token (as C++ streams print them) anywhere in the text: no computed number a
// user reads may be one (veil prints n/a, "-" or JSON null and says why).
inline bool hasNonFinite(const std::string& text) {
    auto word = [&](size_t i) {
        return i < text.size() && (std::isalpha(static_cast<unsigned char>(text[i])) ||
                                   text[i] == '_');
    };
    for (const char* token : {"inf", "nan"})
        for (size_t at = text.find(token); at != std::string::npos;
             at = text.find(token, at + 1))
            if ((at == 0 || !word(at - 1)) && !word(at + 3)) return true;
    return false;
}

}  // namespace veil_test
