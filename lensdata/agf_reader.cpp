#include "lensdata/agf_reader.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <ostream>
#include <sstream>

#include "lensdata/errors.h"
#include "lensdata/text_decoding.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const AgfCatalog& c) {
    return os << "AgfCatalog{" << c.name << ", " << c.glasses.size() << " glasses, "
              << c.comments.size() << " comments}";
}

// AGF Parsing

namespace {

bool isBlank(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; }

std::string upper(std::string_view s) {
    std::string u(s);
    for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return u;
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && isBlank(s.front())) s.remove_prefix(1);
    while (!s.empty() && isBlank(s.back())) s.remove_suffix(1);
    return s;
}

struct Token {
    std::string_view text;
    size_t offset = 0;  // byte offset in the line
};

// The state of one parse: where we are, which glass and catalog lines go to.
class AgfParser {
  public:
    AgfParser(std::string_view text, const std::string& fileName, const std::string& defaultCatalog)
        : text_(text), fileName_(fileName) {
        catalogs_.push_back({defaultCatalog, {}, {}});
    }

    std::vector<AgfCatalog> run() {
        size_t pos = 0;
        while (pos < text_.size()) {
            size_t end = text_.find_first_of("\r\n", pos);
            if (end == std::string_view::npos) end = text_.size();
            line_ = text_.substr(pos, end - pos);
            ++lineNumber_;
            parseLine();
            pos = end;
            if (pos < text_.size() && text_[pos] == '\r') ++pos;
            if (pos < text_.size() && text_[pos] == '\n') ++pos;
        }
        finishGlass();
        // The default catalog only exists when something was put in it.
        if (catalogs_.size() > 1 && catalogs_.front().glasses.empty())
            catalogs_.erase(catalogs_.begin());
        return std::move(catalogs_);
    }

  private:
    // Glass fields that may appear once per glass.
    enum Seen { kSeenGc = 1, kSeenEd = 2, kSeenCd = 4, kSeenTd = 8, kSeenLd = 16 };

    [[noreturn]] void fail(size_t offset, const std::string& message) const {
        // Columns count characters, not bytes: skip UTF-8 continuation bytes.
        int column = 1;
        for (size_t i = 0; i < offset && i < line_.size(); ++i)
            if ((static_cast<unsigned char>(line_[i]) & 0xC0) != 0x80) ++column;
        throw ParseError(FileLoc{fileName_, lineNumber_, column}, message);
    }

    void tokenize() {
        tokens_.clear();
        size_t i = 0;
        while (i < line_.size()) {
            while (i < line_.size() && isBlank(line_[i])) ++i;
            if (i >= line_.size()) break;
            const size_t start = i;
            while (i < line_.size() && !isBlank(line_[i])) ++i;
            tokens_.push_back({line_.substr(start, i - start), start});
        }
    }

    double number(size_t index, std::string_view what) const {
        if (index >= tokens_.size())
            fail(line_.size(),
                 std::string(tokens_[0].text) + " line is missing " + std::string(what));
        const Token& t = tokens_[index];
        std::string_view s = t.text;
        if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);
        double value = 0.0;
        const auto r = std::from_chars(s.data(), s.data() + s.size(), value);
        if (r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(value)) {
            fail(t.offset, "expected a number for " + std::string(what) + ", got '" +
                               std::string(t.text) + "'");
        }
        return value;
    }

    // A number that AGF files may leave out by writing "-": NaN then.
    double optionalNumber(size_t index, std::string_view what) const {
        if (index < tokens_.size() && tokens_[index].text == "-")
            return std::numeric_limits<double>::quiet_NaN();
        return number(index, what);
    }

    int integer(size_t index, std::string_view what) const {
        const double v = number(index, what);
        if (v != std::floor(v) || std::abs(v) > 1e9)
            fail(tokens_[index].offset, "expected an integer for " + std::string(what) + ", got '" +
                                            std::string(tokens_[index].text) + "'");
        return static_cast<int>(v);
    }

    std::vector<double> numbers(size_t from, std::string_view what, bool dashIsNaN = false) const {
        std::vector<double> v;
        v.reserve(tokens_.size() > from ? tokens_.size() - from : 0);
        for (size_t i = from; i < tokens_.size(); ++i)
            v.push_back(dashIsNaN ? optionalNumber(i, what) : number(i, what));
        return v;
    }

    // Text after the tag, trimmed.
    std::string_view restOfLine() const {
        return trim(line_.substr(tokens_[0].offset + tokens_[0].text.size()));
    }

    Glass& currentGlass() {
        if (!glass_)
            fail(tokens_[0].offset, std::string(tokens_[0].text) + " line before any NM line");
        return *glass_;
    }

    void once(Seen flag) {
        if (seen_ & flag)
            fail(tokens_[0].offset, "second " + std::string(tokens_[0].text) + " line for glass '" +
                                        glass_->name() + "'");
        seen_ |= flag;
    }

    void finishGlass() {
        if (!glass_) return;
        // Without its CD line a glass has no index at all (it was read as 1.0, vacuum, with
        // no word: a lens's EFL went from +100 to -87 mm).
        if (!(seen_ & kSeenCd))
            throw ParseError(FileLoc{fileName_, nmLine_, 1},
                             "glass '" + glass_->name() +
                                 "' has no CD line (its dispersion coefficients) before the "
                                 "next glass or the end of the catalog");
        std::stable_sort(glass_->transmittance.begin(), glass_->transmittance.end(),
                         [](const TransmittancePoint& a, const TransmittancePoint& b) {
                             return a.wavelengthNm < b.wavelengthNm;
                         });
        glass_ = nullptr;
    }

    void parseLine() {
        tokenize();
        if (tokens_.empty()) return;
        const std::string_view tag = tokens_[0].text;
        if (tag == "NM") return parseNm();
        if (tag == "CC") return parseCc();
        if (tag == "GC") {
            Glass& g = currentGlass();
            once(kSeenGc);
            g.comment = std::string(restOfLine());
        } else if (tag == "ED") {
            Glass& g = currentGlass();
            once(kSeenEd);
            g.extraData = numbers(1, "ED data", true);
        } else if (tag == "CD") {
            Glass& g = currentGlass();
            once(kSeenCd);
            g = g.withCoefficients(numbers(1, "a dispersion coefficient"));
        } else if (tag == "TD") {
            Glass& g = currentGlass();
            once(kSeenTd);
            g.thermalData = numbers(1, "TD data", true);
        } else if (tag == "LD") {
            Glass& g = currentGlass();
            once(kSeenLd);
            g.minWavelengthNm = number(1, "the minimum wavelength (um)") * 1e3;
            g.maxWavelengthNm = number(2, "the maximum wavelength (um)") * 1e3;
        } else if (tag == "IT") {
            parseIt(currentGlass());
        }
        // Any other tag (OD, BD, MC, "!" comments, free text) is not used by veil.
    }

    void parseNm() {
        finishGlass();
        if (tokens_.size() < 2) fail(line_.size(), "NM line is missing the glass name");
        const std::string name(tokens_[1].text);
        const int formulaNumber = integer(2, "the dispersion formula number");
        const auto formula = dispersionFormulaFromAgf(formulaNumber);
        if (!formula) {
            fail(tokens_[2].offset, "unknown dispersion formula " + std::to_string(formulaNumber) +
                                        " for glass '" + name + "' (AGF formulas are 1..13)");
        }
        if (tokens_.size() < 4) fail(line_.size(), "NM line is missing the MIL code");
        AgfCatalog& catalog = catalogs_[current_];
        Glass glass(name, catalog.name, *formula, {});
        glass.milCode = std::string(tokens_[3].text);
        glass.ndCatalog = number(4, "nd");
        glass.vdCatalog = number(5, "vd");
        // The optional fields may be "-" (not given).
        const auto given = [&](size_t i) { return tokens_.size() > i && tokens_[i].text != "-"; };
        if (given(6)) glass.excludeSubstitution = number(6, "exclude") != 0.0;
        if (given(7)) {
            const int status = integer(7, "the glass status");
            if (status < 0 || status > 4)
                fail(tokens_[7].offset,
                     "unknown glass status " + std::to_string(status) + " (AGF status is 0..4)");
            glass.status = static_cast<GlassStatus>(status);
        }
        if (given(8)) glass.meltFrequency = integer(8, "the melt frequency");

        auto& lines = firstLine_[current_];
        const auto [it, inserted] = lines.emplace(upper(name), lineNumber_);
        if (!inserted) {
            fail(tokens_[1].offset, "glass '" + name + "' is defined twice in catalog " +
                                        catalog.name + " (first at line " +
                                        std::to_string(it->second) + ")");
        }
        catalog.glasses.push_back(std::move(glass));
        glass_ = &catalog.glasses.back();
        seen_ = 0;
        nmLine_ = lineNumber_;
    }

    void parseCc() {
        const std::string_view text = restOfLine();
        constexpr std::string_view kMarker = "veil-catalog";
        if (text.substr(0, kMarker.size()) == kMarker &&
            (text.size() == kMarker.size() || isBlank(text[kMarker.size()]))) {
            finishGlass();
            const std::string_view name = trim(text.substr(kMarker.size()));
            if (name.empty() || std::any_of(name.begin(), name.end(), isBlank))
                fail(tokens_[0].offset, "veil-catalog marker needs one catalog name");
            startCatalog(std::string(name));
            return;
        }
        catalogs_[current_].comments.emplace_back(text);
    }

    void startCatalog(std::string name) {
        const std::string key = upper(name);
        for (size_t i = 0; i < catalogs_.size(); ++i) {
            if (upper(catalogs_[i].name) == key) {
                current_ = i;
                return;
            }
        }
        catalogs_.push_back({std::move(name), {}, {}});
        current_ = catalogs_.size() - 1;
    }

    void parseIt(Glass& g) {
        TransmittancePoint p;
        p.wavelengthNm = number(1, "the wavelength (um)") * 1e3;
        if (tokens_.size() == 3) {
            // "IT lambda  thickness": the transmittance is blank, below the measurable limit.
            p.thicknessMm = number(2, "the thickness (mm)");
        } else {
            p.internalTransmittance = number(2, "the internal transmittance");
            p.thicknessMm = number(3, "the thickness (mm)");
            if (p.internalTransmittance < 0.0 || p.internalTransmittance > 1.0)
                fail(tokens_[2].offset, "internal transmittance must lie in [0, 1]");
        }
        if (!(p.wavelengthNm > 0.0)) fail(tokens_[1].offset, "wavelength must be > 0");
        if (!(p.thicknessMm > 0.0))
            fail(tokens_[tokens_.size() == 3 ? 2 : 3].offset, "thickness must be > 0");
        g.transmittance.push_back(p);
    }

    std::string_view text_;
    const std::string& fileName_;
    std::vector<AgfCatalog> catalogs_;
    std::map<size_t, std::map<std::string, int>> firstLine_;  // catalog -> NAME -> NM line
    size_t current_ = 0;
    Glass* glass_ = nullptr;
    unsigned seen_ = 0;
    std::string_view line_;
    int lineNumber_ = 0;
    int nmLine_ = 0;  // the current glass's NM line
    std::vector<Token> tokens_;
};

}  // namespace

std::vector<AgfCatalog> parseAgf(std::string_view text, const std::string& fileName,
                                 const std::string& defaultCatalog) {
    return AgfParser(text, fileName, defaultCatalog).run();
}

std::vector<AgfCatalog> readAgfFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw ParseError(FileLoc{path}, "cannot open glass catalog file");
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw ParseError(FileLoc{path}, "cannot read glass catalog file");
    const std::string text = decodeText(bytes, path);
    return parseAgf(text, path, upper(std::filesystem::path(path).stem().string()));
}

// AGF Writing

namespace {

// The shortest decimal that reads back as `v`; fixed notation unless scientific is more
// than one character shorter ("0.0002", not "2e-04"; "1.86e-06", not "0.00000186").
std::string shortest(double v) {
    if (std::isnan(v)) return "-";  // AGF's "not given"
    char fixed[400], sci[32];
    const auto f = std::to_chars(fixed, fixed + sizeof(fixed), v, std::chars_format::fixed);
    const auto e = std::to_chars(sci, sci + sizeof(sci), v, std::chars_format::scientific);
    if (f.ec == std::errc() && f.ptr - fixed <= e.ptr - sci + 1) return std::string(fixed, f.ptr);
    return std::string(sci, e.ptr);
}

// A wavelength stored in nm, written in um with 12 significant digits: enough for any
// catalog value, and it hides the rounding of the nm <-> um conversion.
std::string micrometres(double nm) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof(buf), nm * 1e-3, std::chars_format::general, 12);
    return std::string(buf, r.ptr);
}

void writeNumbers(std::ostream& os, std::string_view tag, const std::vector<double>& v) {
    os << tag;
    for (double x : v) os << ' ' << shortest(x);
    os << '\n';
}

}  // namespace

void writeAgf(std::ostream& os, const AgfCatalog& catalog) {
    os << "CC veil-catalog " << catalog.name << '\n';
    for (const std::string& c : catalog.comments) os << "CC " << c << '\n';
    for (const Glass& g : catalog.glasses) {
        if (g.formula() == DispersionFormula::Model) {
            throw std::invalid_argument("writeAgf: model glass '" + g.name() +
                                        "' has no AGF dispersion formula");
        }
        const double nd = std::isnan(g.ndCatalog) ? g.index(kLineD) : g.ndCatalog;
        const double vd = std::isnan(g.vdCatalog) ? g.abbeNumber() : g.vdCatalog;
        os << "NM " << g.name() << ' ' << static_cast<int>(g.formula()) << ' '
           << (g.milCode.empty() ? std::string("0") : g.milCode) << ' ' << shortest(nd) << ' '
           << shortest(vd) << ' ' << (g.excludeSubstitution ? 1 : 0) << ' '
           << static_cast<int>(g.status) << ' ' << g.meltFrequency << '\n';
        if (!g.comment.empty()) os << "GC " << g.comment << '\n';
        if (!g.extraData.empty()) writeNumbers(os, "ED", g.extraData);
        // Trailing zero coefficients are implied (missing coefficients are zero).
        std::vector<double> cd = g.coefficients();
        while (!cd.empty() && cd.back() == 0.0) cd.pop_back();
        if (cd.empty()) cd.push_back(0.0);
        writeNumbers(os, "CD", cd);
        if (!g.thermalData.empty()) writeNumbers(os, "TD", g.thermalData);
        if (g.minWavelengthNm > 0.0 || g.maxWavelengthNm > 0.0)
            os << "LD " << micrometres(g.minWavelengthNm) << ' ' << micrometres(g.maxWavelengthNm)
               << '\n';
        for (const TransmittancePoint& p : g.transmittance) {
            os << "IT " << micrometres(p.wavelengthNm) << ' ' << shortest(p.internalTransmittance)
               << ' ' << shortest(p.thicknessMm) << '\n';
        }
    }
}

}  // namespace veil
