#pragma once
// Glass catalogs: the built-in one and AGF files the user names.
//
// The built-in catalog holds the complete Schott, Ohara and CDGM catalogs (regenerated from
// AGF files with tools/glassgen, kept in lensdata/data/builtin_glass.agf) and the crystals
// of lensdata/data/crystals.agf: fused silica, CaF2, sapphire. More catalogs come from AGF
// files at run time: a command-line option or the VEIL_GLASS_PATH environment variable
// (a ':'-separated list of .agf files or folders holding them).
//
// One AGF file may hold several catalogs (veil extension, see lensdata/agf_reader.h): a line
//   CC veil-catalog NAME
// starts catalog NAME; what follows belongs to it up to the next marker. builtin_glass.agf
// uses it for SCHOTT, OHARA and CDGM, crystals.agf for CRYSTALS. Other AGF readers take the
// marker for a comment. Catalog and glass names compare case-insensitively.

#include <filesystem>
#include <map>
#include <memory>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lensdata/glass.h"

namespace veil {

// What to tell a user whose file names a glass no loaded catalog has.
inline constexpr const char* kGlassCatalogHint =
    "load a catalog that has it with --glass-catalog FILE.AGF or VEIL_GLASS_PATH=FILE_OR_FOLDER";

class GlassCatalog {
  public:
    GlassCatalog() = default;

    // Schott, Ohara, CDGM and crystals (catalogs SCHOTT, OHARA, CDGM, CRYSTALS, in that
    // order), compiled into the program and parsed once, on first use (thread-safe).
    static const GlassCatalog& builtIn();
    // builtIn() plus every catalog named by VEIL_GLASS_PATH. Throws ParseError for a bad file
    // or an entry that does not exist (naming it).
    static GlassCatalog withEnvironment();

    // Reads an AGF file (ASCII, UTF-8, or UTF-16 LE/BE with BOM). The catalog is named after
    // the file stem in upper case ("SCHOTT"), or by veil-catalog markers in the file.
    // Malformed lines throw ParseError with file:line:col; a file that cannot be read throws
    // ParseError naming it. A catalog of the same name replaces the old one in place.
    void loadAgf(const std::filesystem::path& path);
    // Same from text already in memory; `fileName` is used in error messages and to name
    // the catalog when `catalogName` is empty.
    void loadAgfText(std::string_view text, const std::string& fileName,
                     const std::string& catalogName = {});
    // Loads a ':'-separated list of AGF files and folders (every *.agf in a folder, in name
    // order; the extension compares case-insensitively), the VEIL_GLASS_PATH syntax. Empty
    // entries are skipped; a missing entry throws ParseError naming it.
    void loadPathList(std::string_view pathList);
    // Adds a glass to its catalog (glass.catalog(), created if new), replacing a glass of the
    // same name there.
    void add(Glass glass);

    // Case-insensitive lookup. Catalogs listed in `preferred` are searched first, in that
    // order (a lens file's GCAT line), then all others in load order. nullptr if unknown.
    const Glass* find(std::string_view name, std::span<const std::string> preferred = {}) const;
    // Names of all catalogs, in load order.
    std::vector<std::string> catalogNames() const;
    // Glasses of one catalog (empty if unknown).
    std::vector<const Glass*> glasses(std::string_view catalog) const;
    // The CC comment lines of one catalog (empty if unknown).
    std::vector<std::string> comments(std::string_view catalog) const;
    size_t size() const;
    // Up to `count` known names closest to `name` by edit distance (case-insensitive
    // Damerau-Levenshtein), nearest first, for "unknown glass, did you mean". Names further
    // than max(2, name.size() / 2) edits are not suggested.
    std::vector<std::string> suggestions(std::string_view name, int count = 3) const;

  private:
    struct Catalog {
        std::string name;
        std::vector<std::string> comments;
        std::vector<Glass> glasses;
        std::map<std::string, size_t> byUpperName;
    };
    Catalog* catalogNamed(std::string_view name);
    const Catalog* catalogNamed(std::string_view name) const;
    std::vector<Catalog> catalogs_;
};
// "GlassCatalog{SCHOTT: 160, OHARA: 417, CDGM: 162, CRYSTALS: 3}"
std::ostream& operator<<(std::ostream& os, const GlassCatalog& c);

}  // namespace veil
