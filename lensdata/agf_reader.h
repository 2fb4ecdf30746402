#pragma once
// AGF glass catalog files (the Zemax/OpticStudio format): decoding, parsing and writing.
// Internal to lensdata: GlassCatalog is the public face; tools/glassgen uses the writer.
//
// An AGF file is a sequence of lines, each starting with a two-letter tag:
//   CC text                       catalog comment
//   NM name formula MIL nd vd [exclude [status [meltFrequency]]]   starts a glass
//   GC text                       glass comment
//   ED tce tce100300 density dPgF ignoreTce      extra data
//   CD c1 c2 ...                  dispersion coefficients for `formula` (1..13, see glass.h)
//   TD D0 D1 D2 E0 E1 lambda_tk Tref             thermal dn/dT data (kept, not applied)
//   LD minUm maxUm                validity range of the formula
//   IT lambdaUm tau thicknessMm   internal transmittance row
// ED and TD values and the optional NM fields may be "-", meaning not given (NaN, or the
// field's default). Lines with other tags (OD, BD, MC, "!" comments, free text) are skipped.
// Every line after NM belongs to that glass; GC/ED/CD/TD/LD/IT before any NM is an error.
// Schott leaves the transmittance of an IT row blank where it is below the measurable limit
// ("IT 0.29  25"); such a row reads as tau = 0.
//
// veil extension, several catalogs in one file: a line
//   CC veil-catalog NAME
// starts catalog NAME; the glasses and CC lines that follow belong to it, up to the next such
// line. Glasses before the first marker belong to the default catalog (the file stem). Other
// AGF readers see the marker as an ordinary comment.
//
// Text encodings: ASCII/UTF-8 (with or without BOM) and UTF-16 LE or BE with BOM (what
// OpticStudio writes). A UTF-16 file without BOM is recognised by its zero bytes.

#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include "lensdata/glass.h"

namespace veil {

// One catalog read from AGF text.
struct AgfCatalog {
    std::string name;
    std::vector<std::string> comments;  // CC lines, without the tag
    std::vector<Glass> glasses;         // in file order
};
std::ostream& operator<<(std::ostream& os, const AgfCatalog& c);

// Parses UTF-8 AGF text. `defaultCatalog` names the glasses before any veil-catalog marker
// (that catalog is left out when it has no glasses and a marker follows). Throws ParseError
// with fileName:line:column for malformed input: a non-numeric number field, a glass line
// before any NM, an unknown formula number or status, a missing required field, a second
// GC/ED/CD/TD/LD line for one glass, a glass defined twice in one catalog, a transmittance
// row outside [0, 1] or with thickness <= 0.
std::vector<AgfCatalog> parseAgf(std::string_view text, const std::string& fileName,
                                 const std::string& defaultCatalog);

// Reads the file at `path`: decodeText (text_decoding.h) + parseAgf, default catalog = file stem in
// upper case. Throws ParseError naming the path when it cannot be read.
std::vector<AgfCatalog> readAgfFile(const std::string& path);

// Writes `catalog` as normalized AGF: a "CC veil-catalog NAME" marker, its CC lines, then per
// glass NM, GC (if any), ED, CD, TD, LD, IT lines, numbers in the shortest form that reads
// back to the same double (wavelengths, stored in nm, with 12 significant digits in um).
// OD and other lines are not kept. parseAgf(writeAgf(c)) gives back c, except that trailing
// zero coefficients are dropped and an unknown nd or Vd is written as the formula's value.
void writeAgf(std::ostream& os, const AgfCatalog& catalog);

}  // namespace veil
