#include "lensdata/toml_document.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>

#include "lensdata/input_file.h"

namespace veil {

namespace detail {

// Which keys of one table the readers asked for (known) and read (used).
struct TableUse {
    std::set<std::string, std::less<>> known;
    std::set<std::string, std::less<>> used;
};

struct TomlDocumentState {
    std::string fileName;
    toml::table root;
    std::map<const toml::table*, TableUse> tables;
    // Values set by TomlDocument::set(), with the edit that set them.
    std::map<const toml::node*, std::string> origins;

    FileLoc locOf(const toml::source_region& region) const {
        return {fileName, static_cast<int>(region.begin.line),
                static_cast<int>(region.begin.column)};
    }
    FileLoc locOf(const toml::node& node) const {
        const auto it = origins.find(&node);
        if (it != origins.end()) return {it->second, 0, 0};
        return locOf(node.source());
    }
};

}  // namespace detail

namespace {

// Shortest text that reads back to the same double ("0.1", "1e-05", "inf").
std::string formatNumber(double v) {
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[64];
    auto [end, ec] = std::to_chars(buf, buf + sizeof(buf), v);
    return ec == std::errc() ? std::string(buf, end) : std::to_string(v);
}

std::string typeNameOf(const toml::node& node) {
    switch (node.type()) {
        case toml::node_type::table:
            return "table";
        case toml::node_type::array:
            return "array";
        case toml::node_type::string:
            return "string";
        case toml::node_type::integer:
            return "integer";
        case toml::node_type::floating_point:
            return "floating-point number";
        case toml::node_type::boolean:
            return "boolean";
        case toml::node_type::date:
            return "date";
        case toml::node_type::time:
            return "time";
        case toml::node_type::date_time:
            return "date-time";
        default:
            return "value";
    }
}

std::string withArticle(const std::string& noun) {
    const bool vowel =
        !noun.empty() && std::string_view("aeiou").find(noun[0]) != std::string::npos;
    return (vowel ? "an " : "a ") + noun;
}

std::string joinPath(const std::string& parent, std::string_view key) {
    return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string tableDisplayName(const std::string& path) {
    if (path.empty()) return "the top level";
    if (path.find('[') != std::string::npos) return path;
    return "[" + path + "]";
}

std::string lower(std::string_view s) {
    std::string out(s);
    for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return out;
}

// Optimal string alignment distance: Levenshtein plus adjacent transpositions ("sdd" -> "sd"
// is 1, "cnoic" -> "conic" is 1).
size_t editDistance(std::string_view a, std::string_view b) {
    const size_t n = a.size(), m = b.size();
    std::vector<std::vector<size_t>> d(n + 1, std::vector<size_t>(m + 1));
    for (size_t i = 0; i <= n; ++i) d[i][0] = i;
    for (size_t j = 0; j <= m; ++j) d[0][j] = j;
    for (size_t i = 1; i <= n; ++i) {
        for (size_t j = 1; j <= m; ++j) {
            const size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
            d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
    }
    return d[n][m];
}

struct UnusedKey {
    FileLoc loc;
    std::string message;
};

void collectUnused(const detail::TomlDocumentState& doc, const toml::node& node,
                   const std::string& path, std::vector<UnusedKey>& out, bool openedOnly);

// openedOnly: report unused keys only inside tables some reader opened below the root (the
// readers that would open the others may not have run yet), and only those that misspell a
// key the reader asked for.
void collectUnusedInTable(const detail::TomlDocumentState& doc, const toml::table& table,
                          const std::string& path, std::vector<UnusedKey>& out, bool openedOnly) {
    const auto it = doc.tables.find(&table);
    const detail::TableUse* use = it == doc.tables.end() ? nullptr : &it->second;
    if (openedOnly && !use) return;
    for (auto&& [key, value] : table) {
        const std::string name(key.str());
        if (use && use->used.contains(name)) {
            collectUnused(doc, value, joinPath(path, name), out, openedOnly);
            continue;
        }
        if (openedOnly && path.empty()) continue;
        std::string guess;
        if (use) {
            std::vector<std::string> candidates(use->known.begin(), use->known.end());
            guess = closestSpelling(name, candidates);
        }
        // After an error, a key the reader has not asked for yet may be one it would have
        // read next ('pixels' after a bad 'size_mm'): only a misspelling of a key it asked for
        // explains the error better than the error's own message.
        if (openedOnly && guess.empty()) continue;
        std::string message;
        const toml::table* sub = value.as_table();
        const toml::array* arr = value.as_array();
        if (sub && !sub->is_inline()) {
            message = "unknown table [" + joinPath(path, name) + "]";
        } else if (arr && arr->is_array_of_tables() && !arr->empty() &&
                   !arr->front().as_table()->is_inline()) {
            message = "unknown table [[" + joinPath(path, name) + "]]";
        } else {
            message = "unknown key '" + name + "' " + (path.empty() ? "at " : "in ") +
                      tableDisplayName(path);
        }
        if (!guess.empty()) message += " (did you mean '" + guess + "'?)";
        const bool edited = doc.origins.contains(&value);
        out.push_back({edited ? doc.locOf(value) : doc.locOf(key.source()), std::move(message)});
    }
}

void collectUnused(const detail::TomlDocumentState& doc, const toml::node& node,
                   const std::string& path, std::vector<UnusedKey>& out, bool openedOnly) {
    if (const toml::table* table = node.as_table()) {
        collectUnusedInTable(doc, *table, path, out, openedOnly);
    } else if (const toml::array* array = node.as_array()) {
        for (size_t i = 0; i < array->size(); ++i)
            collectUnused(doc, (*array)[i], path + "[" + std::to_string(i + 1) + "]", out,
                          openedOnly);
    }
}

}  // namespace

// NumberRange Public Methods

bool NumberRange::contains(double v) const {
    if (std::isnan(v)) return false;
    if (std::isinf(v) && !infinityAllowed) return false;
    const bool aboveMin = minExclusive ? v > min : v >= min;
    const bool belowMax = maxExclusive ? v < max : v <= max;
    return aboveMin && belowMax;
}

std::string NumberRange::describe() const {
    const bool hasMin = !(std::isinf(min) && min < 0);
    const bool hasMax = !(std::isinf(max) && max > 0);
    std::string s;
    if (hasMin && hasMax) {
        if (minExclusive && maxExclusive)
            s = "strictly between " + formatNumber(min) + " and " + formatNumber(max);
        else if (!minExclusive && !maxExclusive)
            s = "between " + formatNumber(min) + " and " + formatNumber(max);
        else
            s = std::string("in ") + (minExclusive ? "(" : "[") + formatNumber(min) + ", " +
                formatNumber(max) + (maxExclusive ? ")" : "]");
    } else if (hasMin) {
        s = (minExclusive ? "> " : ">= ") + formatNumber(min);
    } else if (hasMax) {
        s = (maxExclusive ? "< " : "<= ") + formatNumber(max);
    } else {
        s = infinityAllowed ? "a number" : "a finite number";
    }
    return s;
}

std::ostream& operator<<(std::ostream& os, const NumberRange& r) { return os << r.describe(); }

// TomlValue Public Methods

FileLoc TomlValue::loc() const { return doc_->locOf(*node_); }

bool TomlValue::isNumber() const { return node_->is_number(); }
bool TomlValue::isInteger() const { return node_->is_integer(); }
bool TomlValue::isBool() const { return node_->is_boolean(); }
bool TomlValue::isString() const { return node_->is_string(); }
bool TomlValue::isArray() const { return node_->is_array(); }
bool TomlValue::isTable() const { return node_->is_table(); }
std::string TomlValue::typeName() const { return typeNameOf(*node_); }

double TomlValue::asNumber(const NumberRange& range) const {
    double v = 0.0;
    if (const auto* i = node_->as_integer())
        v = static_cast<double>(i->get());
    else if (const auto* f = node_->as_floating_point())
        v = f->get();
    else
        failExpected("a number");
    if (std::isnan(v)) fail(path_ + " is nan; it must be a number");
    if (std::isinf(v) && !range.infinityAllowed)
        fail(path_ + " must be finite (got " + formatNumber(v) + ")");
    if (!range.contains(v))
        fail(path_ + " must be " + range.describe() + " (got " + formatNumber(v) + ")");
    return v;
}

int64_t TomlValue::asInteger(const NumberRange& range) const {
    const auto* i = node_->as_integer();
    if (!i) failExpected("an integer");
    const int64_t v = i->get();
    if (!range.contains(static_cast<double>(v)))
        fail(path_ + " must be " + range.describe() + " (got " + std::to_string(v) + ")");
    return v;
}

bool TomlValue::asBool() const {
    const auto* b = node_->as_boolean();
    if (!b) failExpected("true or false");
    return b->get();
}

std::string TomlValue::asString() const {
    const auto* s = node_->as_string();
    if (!s) failExpected("a string");
    return s->get();
}

TomlTable TomlValue::asTable() const {
    const auto* t = node_->as_table();
    if (!t) failExpected("a table");
    return TomlTable(doc_, t, path_);
}

std::vector<TomlValue> TomlValue::asArray() const {
    const auto* a = node_->as_array();
    if (!a) failExpected("an array");
    std::vector<TomlValue> out;
    out.reserve(a->size());
    for (size_t i = 0; i < a->size(); ++i)
        out.push_back(TomlValue(doc_, &(*a)[i], path_ + "[" + std::to_string(i + 1) + "]"));
    return out;
}

void TomlValue::fail(const std::string& message) const { throw ParseError(loc(), message); }

void TomlValue::failExpected(std::string_view expected) const {
    fail(path_ + " must be " + std::string(expected) + ", not " + withArticle(typeName()));
}

std::ostream& operator<<(std::ostream& os, const TomlValue& v) {
    os << v.path() << " = ";
    v.node().visit([&](const auto& value) { os << value; });
    return os << " (" << v.loc() << ")";
}

// TomlTable Public Methods

TomlTable::TomlTable(detail::TomlDocumentState* doc, const toml::table* table, std::string path)
    : doc_(doc), table_(table), path_(std::move(path)) {}

std::string TomlTable::displayName() const { return tableDisplayName(path_); }

FileLoc TomlTable::loc() const { return doc_->locOf(table_->source()); }

std::string TomlTable::childPath(std::string_view key) const { return joinPath(path_, key); }

bool TomlTable::has(std::string_view key) const {
    doc_->tables[table_].known.emplace(key);
    return table_->contains(key);
}

std::optional<TomlValue> TomlTable::get(std::string_view key) const {
    detail::TableUse& use = doc_->tables[table_];
    use.known.emplace(key);
    const toml::node* node = table_->get(key);
    if (!node) return std::nullopt;
    use.used.emplace(key);
    return TomlValue(doc_, node, childPath(key));
}

TomlValue TomlTable::require(std::string_view key, std::string_view what) const {
    if (auto v = get(key)) return *v;
    std::string message = "missing key '" + std::string(key) + "'";
    if (!what.empty()) message += " (" + std::string(what) + ")";
    fail(message + " in " + displayName());
}

double TomlTable::number(std::string_view key, double fallback, const NumberRange& range) const {
    const auto v = get(key);
    return v ? v->asNumber(range) : fallback;
}

bool TomlTable::boolean(std::string_view key, bool fallback) const {
    const auto v = get(key);
    return v ? v->asBool() : fallback;
}

std::string TomlTable::string(std::string_view key, std::string fallback) const {
    const auto v = get(key);
    return v ? v->asString() : fallback;
}

void TomlTable::fail(const std::string& message) const { throw ParseError(loc(), message); }

std::ostream& operator<<(std::ostream& os, const TomlTable& t) {
    return os << t.displayName() << " (" << t.loc() << ")";
}

// TomlDocument Public Methods

TomlDocument::TomlDocument(std::unique_ptr<detail::TomlDocumentState> state)
    : state_(std::move(state)) {}
TomlDocument::TomlDocument(TomlDocument&&) noexcept = default;
TomlDocument& TomlDocument::operator=(TomlDocument&&) noexcept = default;
TomlDocument::~TomlDocument() = default;

TomlDocument TomlDocument::fromFile(const std::filesystem::path& path) {
    const std::optional<std::string> text = readInputFile(path);
    if (!text) throw ParseError({path.string(), 0, 0}, "cannot open file");
    return fromString(*text, path.string());
}

namespace {

// toml++ parses a dotted key (a.b.c = 1, [a.b.c]) by recursion, one level per part: a key of
// some 30000 parts exhausts the stack. Keys are scanned first, outside strings and comments:
// the dots between two of = , { } [ ] or a line end are counted, and a run of more than
// kMaxDottedKeyParts - 1 is refused at its last dot. (Values hold few dots: 1.5, a date.)
void checkDottedKeys(std::string_view text, const std::string& fileName) {
    enum class State { Normal, Comment, Basic, Literal, MultiBasic, MultiLiteral };
    State state = State::Normal;
    int line = 1, column = 0, dots = 0;
    for (size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        ++column;
        auto opens = [&](std::string_view q) { return text.substr(i, q.size()) == q; };
        switch (state) {
            case State::Comment:
                if (c == '\n') state = State::Normal;
                break;
            case State::Basic:
                if (c == '\\' && i + 1 < text.size() && text[i + 1] != '\n') {
                    ++i;
                    ++column;
                } else if (c == '"' || c == '\n') {
                    state = State::Normal;
                }
                break;
            case State::Literal:
                if (c == '\'' || c == '\n') state = State::Normal;
                break;
            case State::MultiBasic:
                if (c == '\\' && i + 1 < text.size() && text[i + 1] != '\n') {
                    ++i;
                    ++column;
                } else if (opens("\"\"\"")) {
                    state = State::Normal;
                    i += 2;
                    column += 2;
                }
                break;
            case State::MultiLiteral:
                if (opens("\'\'\'")) {
                    state = State::Normal;
                    i += 2;
                    column += 2;
                }
                break;
            case State::Normal:
                if (c == '#') {
                    state = State::Comment;
                } else if (c == '"') {
                    state = opens("\"\"\"") ? State::MultiBasic : State::Basic;
                    if (state == State::MultiBasic) i += 2, column += 2;
                } else if (c == '\'') {
                    state = opens("\'\'\'") ? State::MultiLiteral : State::Literal;
                    if (state == State::MultiLiteral) i += 2, column += 2;
                } else if (c == '.') {
                    if (++dots >= kMaxDottedKeyParts)
                        throw ParseError({fileName, line, column},
                                         "a dotted key of more than " +
                                             std::to_string(kMaxDottedKeyParts) + " parts");
                } else if (c == '=' || c == ',' || c == '{' || c == '}' || c == '[' || c == ']' ||
                           c == '\n') {
                    dots = 0;
                }
                break;
        }
        if (c == '\n') {
            ++line;
            column = 0;
            if (state != State::MultiBasic && state != State::MultiLiteral) dots = 0;
        }
    }
}

}  // namespace

TomlDocument TomlDocument::fromString(std::string_view text, std::string fileName) {
    checkDottedKeys(text, fileName);
    auto state = std::make_unique<detail::TomlDocumentState>();
    state->fileName = std::move(fileName);
    try {
        state->root = toml::parse(text, std::string_view(state->fileName));
    } catch (const toml::parse_error& e) {
        std::string message(e.description());
        // The most common surprise for people new to TOML: { ... } cannot span lines.
        if (message.find("inline table") != std::string::npos &&
            message.find("\\n") != std::string::npos)
            message += " (an inline table { ... } must be written on one line)";
        throw ParseError(state->locOf(e.source()), message);
    }
    return TomlDocument(std::move(state));
}

const std::string& TomlDocument::fileName() const { return state_->fileName; }

TomlTable TomlDocument::root() const { return TomlTable(state_.get(), &state_->root, ""); }

namespace {

// The parts of a key path: "a.b[2].c" and "a.b.2.c" both give a, b, 2, c.
std::vector<std::string> keyPathParts(std::string_view path) {
    std::vector<std::string> parts;
    std::string cur;
    for (char c : path) {
        if (c == '.' || c == '[' || c == ']') {
            if (!cur.empty()) parts.push_back(std::move(cur));
            cur.clear();
        } else {
            cur += c;
        }
    }
    if (!cur.empty()) parts.push_back(std::move(cur));
    return parts;
}

// A whole-text integer or number, else nullopt.
std::optional<int64_t> parseInteger(std::string_view text) {
    int64_t v = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
    return v;
}
std::optional<double> parseNumber(std::string_view text) {
    double v = 0.0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
    return v;
}

// A string value as written: a value in TOML quotes ("x" or 'x', as a TOML user types it)
// is the text inside them (\" and \\ unescaped in double quotes); anything else is itself.
std::string unquoted(std::string_view text) {
    if (text.size() >= 2 && text.front() == '\'' && text.back() == '\'')
        return std::string(text.substr(1, text.size() - 2));
    if (text.size() >= 2 && text.front() == '"' && text.back() == '"') {
        std::string out;
        for (size_t i = 1; i + 1 < text.size(); ++i) {
            if (text[i] == '\\' && i + 2 < text.size() && (text[i + 1] == '"' || text[i + 1] == '\\'))
                ++i;
            out += text[i];
        }
        return out;
    }
    return std::string(text);
}

// The value `text` stands for where `old` stood (nullptr: a new key).
template <class Fail>
void assignValue(const toml::node* old, std::string_view text, const std::string& path, Fail fail,
                 std::function<void(toml::node&&)> put) {
    const std::optional<int64_t> i = parseInteger(text);
    const std::optional<double> x = parseNumber(text);
    const bool isBool = text == "true" || text == "false";
    if (!old) {
        if (i)
            put(toml::value<int64_t>(*i));
        else if (x)
            put(toml::value<double>(*x));
        else if (isBool)
            put(toml::value<bool>(text == "true"));
        else
            put(toml::value<std::string>(unquoted(text)));
        return;
    }
    if (old->is_table() || old->is_array())
        fail(path + " is " + withArticle(typeNameOf(*old)) + "; name one of its values (" + path +
             (old->is_array() ? "[1]" : ".key") + ")");
    if (old->is_number()) {
        if (i && old->is_integer())
            put(toml::value<int64_t>(*i));
        else if (x)
            put(toml::value<double>(*x));
        else
            fail(path + " is a number in the file; '" + std::string(text) + "' is not one");
    } else if (old->is_boolean()) {
        if (!isBool) fail(path + " is true or false in the file, not '" + std::string(text) + "'");
        put(toml::value<bool>(text == "true"));
    } else if (old->is_string()) {
        put(toml::value<std::string>(unquoted(text)));
    } else {
        fail(path + " is " + withArticle(typeNameOf(*old)) + ", which cannot be varied");
    }
}

}  // namespace

void TomlDocument::eraseIfPresent(std::string_view tablePath, const std::string& name) {
    toml::node* node = &state_->root;
    for (const std::string& part : keyPathParts(tablePath)) {
        toml::table* table = node->as_table();
        node = table ? table->get(part) : nullptr;
        if (!node) return;
    }
    toml::table* table = node->as_table();
    if (!table) return;
    // An edit's origin is keyed by its node: the key goes, and so does that entry (a later
    // node at the same address must not inherit it).
    if (const toml::node* gone = table->get(name)) state_->origins.erase(gone);
    table->erase(name);
}

void TomlDocument::set(std::string_view keyPath, std::string_view valueText,
                       const std::string& origin) {
    auto fail = [&](const std::string& message) -> void {
        throw ParseError({origin, 0, 0}, message);
    };
    const std::vector<std::string> parts = keyPathParts(keyPath);
    if (parts.empty()) fail("an empty key");
    toml::node* node = &state_->root;
    std::string path;
    for (size_t k = 0; k < parts.size(); ++k) {
        const std::string& part = parts[k];
        const bool last = k + 1 == parts.size();
        if (toml::table* table = node->as_table()) {
            const std::string childPath = joinPath(path, part);
            toml::node* child = table->get(part);
            if (last) {
                assignValue(child, valueText, childPath, fail, [&](toml::node&& v) {
                    v.visit([&](auto&& value) { table->insert_or_assign(part, std::move(value)); });
                });
                state_->origins[table->get(part)] = origin;
                return;
            }
            if (!child) {
                std::vector<std::string> keys;
                for (auto&& [key, value] : *table) keys.emplace_back(key.str());
                const std::string guess = closestSpelling(part, keys);
                std::string message =
                    "no '" + part + "' in " + tableDisplayName(path) + " of " + state_->fileName;
                if (!guess.empty()) message += " (did you mean '" + guess + "'?)";
                fail(message);
            }
            node = child;
            path = childPath;
        } else if (toml::array* array = node->as_array()) {
            size_t index = 0;
            if (const auto i = parseInteger(part)) {
                if (*i < 1 || *i > static_cast<int64_t>(array->size()))
                    fail(path + " has " + std::to_string(array->size()) +
                         " entries, counted from 1; there is no entry " + part);
                index = static_cast<size_t>(*i - 1);
            } else {
                std::vector<std::string> names;
                for (; index < array->size(); ++index) {
                    const toml::table* t = (*array)[index].as_table();
                    const toml::node* name = t ? t->get("name") : nullptr;
                    if (name && name->is_string()) {
                        names.push_back(name->as_string()->get());
                        if (names.back() == part) break;
                    }
                }
                if (index == array->size())
                    fail("no entry named '" + part + "' in " + path +
                         (names.empty() ? std::string(" (its entries have no names)")
                                        : " (named: " +
                                              [&] {
                                                  std::string all;
                                                  for (const std::string& n : names)
                                                      all += (all.empty() ? "" : ", ") + n;
                                                  return all;
                                              }() +
                                              ")"));
            }
            const std::string childPath = path + "[" + std::to_string(index + 1) + "]";
            if (last) {
                assignValue(&(*array)[index], valueText, childPath, fail, [&](toml::node&& v) {
                    v.visit([&](auto&& value) {
                        array->replace(array->cbegin() + static_cast<std::ptrdiff_t>(index),
                                       std::move(value));
                    });
                });
                state_->origins[&(*array)[index]] = origin;
                return;
            }
            node = &(*array)[index];
            path = childPath;
        } else {
            fail(path + " is " + withArticle(typeNameOf(*node)) + ", not a table: it has no '" +
                 part + "'");
        }
    }
}

void TomlDocument::checkAllUsed() const { check(false); }

void TomlDocument::checkUsedInOpenedTables() const { check(true); }

void TomlDocument::check(bool openedOnly) const {
    std::vector<UnusedKey> unused;
    collectUnusedInTable(*state_, state_->root, "", unused, openedOnly);
    if (unused.empty()) return;
    const auto first =
        std::min_element(unused.begin(), unused.end(), [](const UnusedKey& a, const UnusedKey& b) {
            return std::pair(a.loc.line, a.loc.column) < std::pair(b.loc.line, b.loc.column);
        });
    throw ParseError(first->loc, first->message);
}

// Spelling suggestions

std::string closestSpelling(std::string_view word, const std::vector<std::string>& candidates) {
    const std::string w = lower(word);
    const size_t maxDistance = w.size() <= 3 ? 1 : 2;
    std::string best;
    size_t bestScore = std::numeric_limits<size_t>::max();
    for (const std::string& candidate : candidates) {
        const std::string c = lower(candidate);
        if (c == w && candidate == word) continue;
        size_t score = editDistance(w, c);
        if (score > maxDistance) {
            const std::string& shorter = w.size() < c.size() ? w : c;
            const std::string& longer = w.size() < c.size() ? c : w;
            if (shorter.size() < 3 || longer.compare(0, shorter.size(), shorter) != 0) continue;
            score = maxDistance + 1;  // a prefix ranks after every close misspelling
        }
        if (score < bestScore) {
            bestScore = score;
            best = candidate;
        }
    }
    return best;
}

}  // namespace veil
