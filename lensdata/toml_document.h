#pragma once
// A parsed TOML input file that remembers which keys were read.
//
// A veil scene file has sections owned by different modules: lensdata reads [system], later
// modules read [mechanics], [[source]], [detector] and [properties.*]. Each reader takes the
// tables it owns from one TomlDocument and reads values through TomlTable / TomlValue, which
// record every key asked for and every key used. When all readers are done,
// checkAllUsed() reports the first key (in file order) that nobody read, so a typo is an
// error instead of a silently ignored setting (Mitsuba's property bag; pbrt's unused
// parameter check):
//
//   lens.toml:7:23: unknown key 'sdd' in system.surfaces[2] (did you mean 'sd'?)
//
// Every error is a ParseError at the file:line:col of the value or key at fault:
//
//   TomlDocument doc = TomlDocument::fromFile("lens.toml");  // syntax errors throw here
//   TomlTable system = doc.root().require("system").asTable();
//   double epd = system.number("epd_mm", 10.0, NumberRange::above(0.0));
//   for (const TomlValue& row : system.require("surfaces").asArray()) {
//       TomlTable surface = row.asTable();
//       ...
//   }
//   doc.checkAllUsed();
//
// Naming in messages: tables are "[system]" or "[system.aperture]", the root is "the top
// level"; array entries count from 1 ("system.surfaces[2]" is the second row, which is
// surface 2 of the prescription since the object is surface 0); values are named by their
// full path ("system.surfaces[2].sd").
//
// TomlTable and TomlValue are cheap views into the document: copy them freely, but do not
// use them after the TomlDocument is gone.

#include <toml++/toml.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "lensdata/errors.h"

namespace veil {

class TomlTable;
class TomlValue;

// The values a number may take; the default accepts any finite number. Used by the typed
// getters, which report a value outside the range as a ParseError at the value.
// A dotted key (a.b.c = 1, [a.b.c]) has at most this many parts: the TOML library parses
// them by recursion, so a longer one is a ParseError at its last dot, before parsing.
inline constexpr int kMaxDottedKeyParts = 128;

struct NumberRange {
    double min = -std::numeric_limits<double>::infinity();
    double max = std::numeric_limits<double>::infinity();
    bool minExclusive = false;
    bool maxExclusive = false;
    bool infinityAllowed = false;  // +-inf accepted when inside [min, max]

    static NumberRange any() { return {}; }
    static NumberRange atLeast(double lo) { return {lo}; }
    static NumberRange above(double lo) {
        return {lo, std::numeric_limits<double>::infinity(), true};
    }
    static NumberRange between(double lo, double hi) { return {lo, hi}; }
    static NumberRange strictlyBetween(double lo, double hi) { return {lo, hi, true, true}; }
    NumberRange orInfinite() const {
        NumberRange r = *this;
        r.infinityAllowed = true;
        return r;
    }

    bool contains(double v) const;
    // ">= 0", "> 0", "between 1 and 3", "strictly between -90 and 90", "in [0, 1)"
    std::string describe() const;
};
std::ostream& operator<<(std::ostream& os, const NumberRange& r);

namespace detail {
struct TomlDocumentState;
}

// One value in the document: a scalar, an array or a table. The as*() conversions throw a
// ParseError at the value when it has another type or lies outside the range.
class TomlValue {
  public:
    // Full path for messages: "system.surfaces[2].sd"; array entries count from 1.
    const std::string& path() const { return path_; }
    FileLoc loc() const;

    bool isNumber() const;  // integer or floating point
    bool isInteger() const;
    bool isBool() const;
    bool isString() const;
    bool isArray() const;
    bool isTable() const;
    std::string typeName() const;  // "string", "integer", "table", ... for messages

    double asNumber(const NumberRange& range = {}) const;  // integers convert
    int64_t asInteger(const NumberRange& range = {}) const;
    bool asBool() const;
    std::string asString() const;
    TomlTable asTable() const;
    std::vector<TomlValue> asArray() const;

    // Throws ParseError at this value.
    [[noreturn]] void fail(const std::string& message) const;
    // Same with "<path> must be <expected>, not <a/an type>", for values that may take one of
    // several forms: failExpected("a number or a pair [x, y]").
    [[noreturn]] void failExpected(std::string_view expected) const;

    // The toml++ node, for readers that need a type not covered here (dates, times).
    const toml::node& node() const { return *node_; }

  private:
    friend class TomlTable;
    TomlValue(detail::TomlDocumentState* doc, const toml::node* node, std::string path)
        : doc_(doc), node_(node), path_(std::move(path)) {}

    detail::TomlDocumentState* doc_;
    const toml::node* node_;
    std::string path_;
};
std::ostream& operator<<(std::ostream& os, const TomlValue& v);

// A table of the document (a [section], an inline table or an entry of an array of tables).
// Reading a key marks it used; asking whether it exists (has) only marks it known, which
// makes it a candidate for "did you mean" suggestions.
class TomlTable {
  public:
    // Dotted path ("system", "system.surfaces[2]"); empty for the root.
    const std::string& path() const { return path_; }
    // "the top level", "[system]", "system.surfaces[2]": how messages name the table.
    std::string displayName() const;
    FileLoc loc() const;

    // Whether `key` is present; marks it known, not used.
    bool has(std::string_view key) const;
    // The value under `key`, marked used; nullopt when absent.
    std::optional<TomlValue> get(std::string_view key) const;
    // Same, but a missing key is a ParseError at the table: "missing key 't' (thickness to
    // the next surface, mm) in system.surfaces[2]"; `what` is the parenthesized hint.
    TomlValue require(std::string_view key, std::string_view what = {}) const;

    // Shorthands for optional scalars: the fallback when absent, a ParseError when present
    // with the wrong type or out of range.
    double number(std::string_view key, double fallback, const NumberRange& range = {}) const;
    bool boolean(std::string_view key, bool fallback) const;
    std::string string(std::string_view key, std::string fallback = {}) const;

    // Throws ParseError at the table.
    [[noreturn]] void fail(const std::string& message) const;

    // The toml++ table. Reading through it bypasses the used-key bookkeeping.
    const toml::table& table() const { return *table_; }

  private:
    friend class TomlValue;
    friend class TomlDocument;
    TomlTable(detail::TomlDocumentState* doc, const toml::table* table, std::string path);
    std::string childPath(std::string_view key) const;

    detail::TomlDocumentState* doc_;
    const toml::table* table_;
    std::string path_;
};
std::ostream& operator<<(std::ostream& os, const TomlTable& t);

class TomlDocument {
  public:
    // Parses a file. A file that cannot be opened is a ParseError naming the file; TOML
    // syntax errors are ParseErrors at their line:col.
    static TomlDocument fromFile(const std::filesystem::path& path);
    // Parses text already in memory; `fileName` is used in every FileLoc.
    static TomlDocument fromString(std::string_view text, std::string fileName = "<string>");

    TomlDocument(TomlDocument&&) noexcept;
    TomlDocument& operator=(TomlDocument&&) noexcept;
    ~TomlDocument();

    const std::string& fileName() const;
    TomlTable root() const;

    // Replaces (or adds) one value, for what-if edits (`veil sweep --vary`). The key path is
    // written as messages write it, "system.surfaces[3].coating", or with dots,
    // "system.surfaces.3.coating" (array entries count from 1); in an array of tables an
    // entry may be named by its `name` key: "source.sun.field_deg[2]". The new value takes
    // the type of the one it replaces (number, integer, string, true/false; an integer given
    // a fraction becomes a number); a new key becomes an integer or a number when the text
    // is one, true/false, else a string. `origin` ("--vary KEY=VALUE") stands for the
    // value's file:line:col in every later message about it. Throws ParseError at `origin`
    // for a path that names nothing (with the keys there) or a value that does not fit.
    void set(std::string_view keyPath, std::string_view valueText, const std::string& origin);
    // Removes the key `name` from the table at `tablePath` (dotted, as set() takes it; "" is
    // the root) when both are there; anything else is left alone.
    void eraseIfPresent(std::string_view tablePath, const std::string& name);

    // Throws ParseError at the first key (in file order) that no reader used:
    // "unknown key 'foo' in [system]", "unknown table [mechanics]"; with "did you mean 'x'?"
    // when a key a reader asked for in the same table is close in spelling. Keys inside a
    // table nobody opened are not listed separately: the table's own key is reported.
    void checkAllUsed() const;
    // The same for the tables below the root that some reader opened only: for a reader that
    // failed part way, whose error a misspelt key in what was read may explain.
    void checkUsedInOpenedTables() const;

  private:
    void check(bool openedOnly) const;
    explicit TomlDocument(std::unique_ptr<detail::TomlDocumentState> state);
    std::unique_ptr<detail::TomlDocumentState> state_;
};

// The closest candidate to `word` when it is close enough to be a plausible misspelling
// (ignoring case: edit distance at most 1 for words of up to 3 letters and at most 2 for
// longer ones, or one word is a prefix of the other of 3 letters or more); empty otherwise.
std::string closestSpelling(std::string_view word, const std::vector<std::string>& candidates);

}  // namespace veil
