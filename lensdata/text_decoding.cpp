#include "lensdata/text_decoding.h"

#include <algorithm>
#include <initializer_list>

#include "lensdata/errors.h"

namespace veil {

// Text Decoding

namespace {

void appendUtf8(std::string& out, char32_t cp) {
    if (cp < 0x80) {
        out += static_cast<char>(cp);
    } else if (cp < 0x800) {
        out += static_cast<char>(0xC0 | (cp >> 6));
        out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
        out += static_cast<char>(0xE0 | (cp >> 12));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
        out += static_cast<char>(0xF0 | (cp >> 18));
        out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
    }
}

std::string decodeUtf16(std::string_view bytes, bool bigEndian, const std::string& fileName) {
    if (bytes.size() % 2 != 0)
        throw ParseError(FileLoc{fileName}, "UTF-16 text with an odd number of bytes");
    std::string out;
    out.reserve(bytes.size() / 2);
    auto unit = [&](size_t i) -> char32_t {
        const auto b0 = static_cast<unsigned char>(bytes[i]);
        const auto b1 = static_cast<unsigned char>(bytes[i + 1]);
        return bigEndian ? (char32_t(b0) << 8 | b1) : (char32_t(b1) << 8 | b0);
    };
    const size_t n = bytes.size();
    for (size_t i = 0; i < n; i += 2) {
        char32_t u = unit(i);
        if (u >= 0xD800 && u < 0xDC00 && i + 3 < n) {
            const char32_t lo = unit(i + 2);
            if (lo >= 0xDC00 && lo < 0xE000) {
                appendUtf8(out, 0x10000 + ((u - 0xD800) << 10) + (lo - 0xDC00));
                i += 2;
                continue;
            }
        }
        if (u >= 0xD800 && u < 0xE000) u = 0xFFFD;  // unpaired surrogate
        appendUtf8(out, u);
    }
    return out;
}

bool isValidUtf8(std::string_view s) {
    for (size_t i = 0; i < s.size();) {
        const auto c = static_cast<unsigned char>(s[i]);
        const int extra = c < 0x80             ? 0
                          : (c & 0xE0) == 0xC0 ? 1
                          : (c & 0xF0) == 0xE0 ? 2
                          : (c & 0xF8) == 0xF0 ? 3
                                               : -1;
        if (extra < 0 || s.size() - i <= static_cast<size_t>(extra)) return false;
        for (int k = 1; k <= extra; ++k)
            if ((static_cast<unsigned char>(s[i + k]) & 0xC0) != 0x80) return false;
        i += extra + 1;
    }
    return true;
}

}  // namespace

std::string decodeText(std::string_view bytes, const std::string& fileName) {
    auto startsWith = [&](std::initializer_list<unsigned char> bom) {
        if (bytes.size() < bom.size()) return false;
        size_t i = 0;
        for (unsigned char b : bom)
            if (static_cast<unsigned char>(bytes[i++]) != b) return false;
        return true;
    };
    if (startsWith({0xEF, 0xBB, 0xBF}))
        bytes.remove_prefix(3);
    else if (startsWith({0xFF, 0xFE}))
        return decodeUtf16(bytes.substr(2), false, fileName);
    else if (startsWith({0xFE, 0xFF}))
        return decodeUtf16(bytes.substr(2), true, fileName);
    else if (bytes.size() >= 2) {
        // No BOM: ASCII text in UTF-16 has a NUL in every other byte (odd offsets for little
        // endian, even offsets for big endian). Text files have no NULs at all, so a clear
        // majority decides.
        const size_t n = std::min<size_t>(bytes.size() & ~size_t(1), 1024);
        size_t evenNul = 0, oddNul = 0;
        for (size_t i = 0; i < n; ++i)
            if (bytes[i] == '\0') (i % 2 ? oddNul : evenNul)++;
        const size_t pairs = n / 2;
        if (oddNul * 2 > pairs && evenNul * 8 < pairs) return decodeUtf16(bytes, false, fileName);
        if (evenNul * 2 > pairs && oddNul * 8 < pairs) return decodeUtf16(bytes, true, fileName);
    }
    if (isValidUtf8(bytes)) return std::string(bytes);
    // Older programs write the Windows code page; read it as Latin-1.
    std::string out;
    out.reserve(bytes.size() + bytes.size() / 8);
    for (char c : bytes) appendUtf8(out, static_cast<unsigned char>(c));
    return out;
}

}  // namespace veil
