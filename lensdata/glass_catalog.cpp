#include "lensdata/glass_catalog.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <tuple>
#include <utility>

#include "lensdata/agf_reader.h"
#include "lensdata/errors.h"
#include "lensdata/text_decoding.h"

namespace veil {

namespace detail {
// lensdata/data/builtin_glass.agf, crystals.agf and vendor_glass.agf, joined by newlines
// (tools/embed_file.cmake).
extern const char kBuiltinGlassData[];
extern const unsigned long kBuiltinGlassDataSize;
}  // namespace detail

namespace {

std::string upper(std::string_view s) {
    std::string u(s);
    for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return u;
}

bool sameName(std::string_view a, std::string_view b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i) {
        if (std::toupper(static_cast<unsigned char>(a[i])) !=
            std::toupper(static_cast<unsigned char>(b[i])))
            return false;
    }
    return true;
}

// Optimal string alignment distance (Levenshtein plus adjacent transpositions).
int editDistance(std::string_view a, std::string_view b) {
    const size_t n = a.size(), m = b.size();
    std::vector<int> prev2(m + 1), prev(m + 1), cur(m + 1);
    for (size_t j = 0; j <= m; ++j) prev[j] = static_cast<int>(j);
    for (size_t i = 1; i <= n; ++i) {
        cur[0] = static_cast<int>(i);
        for (size_t j = 1; j <= m; ++j) {
            const int cost = a[i - 1] == b[j - 1] ? 0 : 1;
            cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + cost});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                cur[j] = std::min(cur[j], prev2[j - 2] + 1);
        }
        std::swap(prev2, prev);
        std::swap(prev, cur);
    }
    return prev[m];
}

}  // namespace

// GlassCatalog Loading

const GlassCatalog& GlassCatalog::builtIn() {
    static const GlassCatalog catalog = [] {
        GlassCatalog c;
        c.loadAgfText(std::string_view(detail::kBuiltinGlassData, detail::kBuiltinGlassDataSize),
                      "<built-in glass data>", "BUILTIN");
        return c;
    }();
    return catalog;
}

GlassCatalog GlassCatalog::withEnvironment() {
    GlassCatalog catalog = builtIn();
    const char* path = std::getenv("VEIL_GLASS_PATH");
    if (path == nullptr) return catalog;
    try {
        catalog.loadPathList(path);
    } catch (const ParseError& e) {
        throw ParseError(e.loc(), e.message() + " (from VEIL_GLASS_PATH)");
    }
    return catalog;
}

void GlassCatalog::loadAgf(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw ParseError(FileLoc{path.string()}, "cannot open glass catalog file");
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw ParseError(FileLoc{path.string()}, "cannot read glass catalog file");
    loadAgfText(bytes, path.string(), upper(path.stem().string()));
}

void GlassCatalog::loadAgfText(std::string_view text, const std::string& fileName,
                               const std::string& catalogName) {
    const std::string defaultName =
        catalogName.empty() ? upper(std::filesystem::path(fileName).stem().string()) : catalogName;
    const std::string decoded = decodeText(text, fileName);
    std::vector<AgfCatalog> parsed = parseAgf(decoded, fileName, defaultName);
    for (AgfCatalog& agf : parsed) {
        Catalog c{std::move(agf.name), std::move(agf.comments), std::move(agf.glasses), {}};
        for (size_t i = 0; i < c.glasses.size(); ++i) c.byUpperName[upper(c.glasses[i].name())] = i;
        if (Catalog* old = catalogNamed(c.name)) {
            *old = std::move(c);
        } else {
            catalogs_.push_back(std::move(c));
        }
    }
}

void GlassCatalog::loadPathList(std::string_view pathList) {
    namespace fs = std::filesystem;
    size_t start = 0;
    while (start <= pathList.size()) {
        size_t end = pathList.find(':', start);
        if (end == std::string_view::npos) end = pathList.size();
        const std::string entry(pathList.substr(start, end - start));
        start = end + 1;
        if (entry.empty()) continue;

        std::error_code ec;
        const fs::file_status st = fs::status(entry, ec);
        if (ec || !fs::exists(st)) throw ParseError(FileLoc{entry}, "glass catalog path not found");
        if (!fs::is_directory(st)) {
            loadAgf(entry);
            continue;
        }
        std::vector<fs::path> files;
        for (const fs::directory_entry& e : fs::directory_iterator(entry, ec)) {
            if (e.is_regular_file() && sameName(e.path().extension().string(), ".agf"))
                files.push_back(e.path());
        }
        if (ec) throw ParseError(FileLoc{entry}, "cannot list glass catalog folder");
        std::sort(files.begin(), files.end());
        for (const fs::path& f : files) loadAgf(f);
    }
}

void GlassCatalog::add(Glass glass) {
    Catalog* c = catalogNamed(glass.catalog());
    if (c == nullptr) {
        catalogs_.push_back({glass.catalog(), {}, {}, {}});
        c = &catalogs_.back();
    }
    const std::string key = upper(glass.name());
    if (auto it = c->byUpperName.find(key); it != c->byUpperName.end()) {
        c->glasses[it->second] = std::move(glass);
    } else {
        c->byUpperName[key] = c->glasses.size();
        c->glasses.push_back(std::move(glass));
    }
}

// GlassCatalog Queries

GlassCatalog::Catalog* GlassCatalog::catalogNamed(std::string_view name) {
    for (Catalog& c : catalogs_)
        if (sameName(c.name, name)) return &c;
    return nullptr;
}

const GlassCatalog::Catalog* GlassCatalog::catalogNamed(std::string_view name) const {
    for (const Catalog& c : catalogs_)
        if (sameName(c.name, name)) return &c;
    return nullptr;
}

const Glass* GlassCatalog::find(std::string_view name,
                                std::span<const std::string> preferred) const {
    const std::string key = upper(name);
    auto lookIn = [&](const Catalog& c) -> const Glass* {
        auto it = c.byUpperName.find(key);
        return it == c.byUpperName.end() ? nullptr : &c.glasses[it->second];
    };
    for (const std::string& p : preferred) {
        if (const Catalog* c = catalogNamed(p))
            if (const Glass* g = lookIn(*c)) return g;
    }
    for (const Catalog& c : catalogs_)
        if (const Glass* g = lookIn(c)) return g;
    return nullptr;
}

const Glass* GlassCatalog::findSuccessor(std::string_view name,
                                         std::span<const std::string> preferred) const {
    if (name.empty() || find(name, preferred)) return nullptr;
    const std::string n(name);
    for (const std::string& candidate :
         {"N-" + n, "N-" + n + "A", "H-" + n, "H-" + n + "L", "H-" + n + "A", "P-" + n})
        if (const Glass* g = find(candidate, preferred)) return g;
    // CDGM's reformulated glasses keep the name with an A (H-ZF7L: H-ZF7LA).
    if (upper(n).rfind("H-", 0) == 0)
        if (const Glass* g = find(n + "A", preferred)) return g;
    const std::string u = upper(n);
    // Schott's older names with an N before the number (SSKN5, LAFN21, BAFN10, KZFSN4): the
    // N moved to the front (N-SSK5, N-LAF21, N-BAF10, N-KZFS4).
    size_t digit = u.find_first_of("0123456789");
    if (digit != std::string::npos && digit >= 3 && u[digit - 1] == 'N' &&
        std::all_of(u.begin(), u.begin() + digit, [](char ch) { return ch >= 'A' && ch <= 'Z'; }))
        if (const Glass* g = find("N-" + u.substr(0, digit - 1) + u.substr(digit), preferred))
            return g;
    // A molded variant (Ohara's L-TIM28_MOLD): the glass it is molded from.
    constexpr std::string_view kMold = "_MOLD";
    if (u.size() > kMold.size() && u.compare(u.size() - kMold.size(), kMold.size(), kMold) == 0)
        if (const Glass* g = find(n.substr(0, n.size() - kMold.size()), preferred)) return g;
    return nullptr;
}

std::vector<std::string> GlassCatalog::catalogNames() const {
    std::vector<std::string> names;
    for (const Catalog& c : catalogs_) names.push_back(c.name);
    return names;
}

std::vector<const Glass*> GlassCatalog::glasses(std::string_view catalog) const {
    std::vector<const Glass*> out;
    if (const Catalog* c = catalogNamed(catalog))
        for (const Glass& g : c->glasses) out.push_back(&g);
    return out;
}

std::vector<std::string> GlassCatalog::comments(std::string_view catalog) const {
    const Catalog* c = catalogNamed(catalog);
    return c ? c->comments : std::vector<std::string>{};
}

size_t GlassCatalog::size() const {
    size_t n = 0;
    for (const Catalog& c : catalogs_) n += c.glasses.size();
    return n;
}

std::vector<std::string> GlassCatalog::suggestions(std::string_view name, int count) const {
    const std::string key = upper(name);
    const int maxDistance = std::max<int>(2, static_cast<int>(key.size()) / 2);
    // The name after a maker's prefix of one or two letters (N-BK7: BK7), else the name.
    auto stem = [](const std::string& n) {
        const size_t dash = n.find('-');
        return dash != std::string::npos && dash >= 1 && dash <= 2 ? n.substr(dash + 1) : n;
    };
    const std::string keyStem = stem(key);
    // (kind, edits, catalog, name): the name itself, then the same stem, then a stem one
    // letter longer or shorter, then the rest within maxDistance edits; ties to the catalog
    // loaded first (Schott's successor before another maker's namesake).
    std::vector<std::tuple<int, int, size_t, std::string>> scored;
    std::set<std::string> seen;
    for (size_t ci = 0; ci < catalogs_.size(); ++ci) {
        for (const Glass& g : catalogs_[ci].glasses) {
            std::string upperName = upper(g.name());
            if (!seen.insert(upperName).second) continue;
            const std::string s = stem(upperName);
            const int d = editDistance(key, upperName);
            int kind = 3;
            if (upperName == key) {
                kind = 0;
            } else if (s == keyStem) {
                kind = 1;
            } else if (!keyStem.empty() && !s.empty() &&
                       (s.rfind(keyStem, 0) == 0 || keyStem.rfind(s, 0) == 0) &&
                       std::max(s.size(), keyStem.size()) - std::min(s.size(), keyStem.size()) <=
                           1) {
                kind = 2;
            }
            if (kind < 3 || d <= maxDistance) scored.emplace_back(kind, d, ci, g.name());
        }
    }
    std::sort(scored.begin(), scored.end());
    std::vector<std::string> out;
    for (auto& t : scored) {
        if (static_cast<int>(out.size()) >= count) break;
        out.push_back(std::move(std::get<3>(t)));
    }
    return out;
}

std::ostream& operator<<(std::ostream& os, const GlassCatalog& c) {
    os << "GlassCatalog{";
    const std::vector<std::string> names = c.catalogNames();
    for (size_t i = 0; i < names.size(); ++i)
        os << (i ? ", " : "") << names[i] << ": " << c.glasses(names[i]).size();
    return os << '}';
}

}  // namespace veil
