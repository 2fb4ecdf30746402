#pragma once
// Decoding of lens and glass files as other programs write them: ASCII, UTF-8 (with or
// without BOM), UTF-16 LE or BE (with a BOM, or recognised without one by the zero bytes
// of ASCII text), and Latin-1 (Windows code page) text that is not valid UTF-8. The result
// is UTF-8 without a BOM. Unpaired UTF-16 surrogates become U+FFFD.

#include <string>
#include <string_view>

namespace veil {

// Throws ParseError naming `fileName` for UTF-16 text with an odd number of bytes.
std::string decodeText(std::string_view bytes, const std::string& fileName);

}  // namespace veil
