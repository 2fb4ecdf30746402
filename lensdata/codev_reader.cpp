#include "lensdata/codev_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "lensdata/errors.h"
#include "lensdata/glass.h"
#include "lensdata/input_file.h"
#include "lensdata/text_decoding.h"

namespace veil {

namespace {

using Severity = ImportNote::Severity;

struct Token {
    std::string text;  // quotes removed
    FileLoc loc;
    bool quoted = false;
};

// One command: its code and its arguments, in file order.
struct Command {
    std::vector<Token> tokens;
    const Token& code() const { return tokens.front(); }
};

std::string upper(std::string s) {
    for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

// Letters and digits only, upper case: how CODE V's glass names compare with a catalog's.
std::string normalized(std::string_view s) {
    std::string out;
    for (char c : s)
        if (std::isalnum(static_cast<unsigned char>(c)))
            out += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return out;
}

// Splits the text into commands: `;` separates them, `!` comments to the end of the line, a
// line whose last token ends in `&` continues on the next, quotes ('...' or "...") hold blanks
// and the other quote character.
std::vector<Command> lex(std::string_view text, const std::string& file) {
    std::vector<Command> out;
    Command pending;
    bool continued = false;
    auto finish = [&] {
        if (!pending.tokens.empty()) out.push_back(std::move(pending));
        pending = Command{};
    };
    int lineNo = 0;
    size_t pos = 0;
    while (pos <= text.size()) {
        const size_t end = std::min(text.find('\n', pos), text.size());
        std::string_view line = text.substr(pos, end - pos);
        pos = end + 1;
        ++lineNo;
        while (!line.empty() &&
               (line.back() == '\r' || std::isspace(static_cast<unsigned char>(line.back()))))
            line.remove_suffix(1);
        if (!continued) finish();
        continued = false;
        size_t i = 0;
        int column = 1;  // characters, for FileLoc
        auto advance = [&](size_t n) {
            for (size_t k = 0; k < n && i < line.size(); ++k, ++i)
                if ((static_cast<unsigned char>(line[i]) & 0xC0) != 0x80) ++column;
        };
        while (i < line.size()) {
            const char c = line[i];
            if (std::isspace(static_cast<unsigned char>(c))) {
                advance(1);
                continue;
            }
            if (c == '!') break;  // a comment to the end of the line
            if (c == ';') {
                finish();
                advance(1);
                continue;
            }
            Token t;
            t.loc = {file, lineNo, column};
            if (c == '\'' || c == '"') {
                const size_t close = line.find(c, i + 1);
                if (close == std::string_view::npos)
                    throw ParseError(
                        t.loc, std::string("unterminated quoted text (no closing ") + c + ")");
                t.text = std::string(line.substr(i + 1, close - i - 1));
                t.quoted = true;
                advance(close + 1 - i);
            } else {
                size_t j = i;
                while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j])) &&
                       line[j] != ';' && line[j] != '!')
                    ++j;
                t.text = std::string(line.substr(i, j - i));
                advance(j - i);
            }
            pending.tokens.push_back(std::move(t));
        }
        // A trailing & continues the command on the next line.
        if (!pending.tokens.empty() && !pending.tokens.back().quoted &&
            !pending.tokens.back().text.empty() && pending.tokens.back().text.back() == '&') {
            pending.tokens.back().text.pop_back();
            if (pending.tokens.back().text.empty()) pending.tokens.pop_back();
            continued = true;
        }
        if (end == text.size()) break;
    }
    finish();
    return out;
}

std::optional<double> parseNumber(const std::string& s) {
    if (s.empty()) return std::nullopt;
    const char* begin = s.c_str();
    char* endp = nullptr;
    const double v = std::strtod(begin, &endp);
    if (endp != begin + s.size() || !std::isfinite(v)) return std::nullopt;
    return v;
}

double number(const Token& t, const std::string& what) {
    const auto v = parseNumber(t.text);
    if (!v) throw ParseError(t.loc, "'" + t.text + "' is not a number (" + what + ")");
    return *v;
}

// A surface as the file gives it, before units and glasses are resolved.
// A surface's decenter (XDE, YDE, ZDE in lens units; ADE, BDE, CDE in degrees) and its type:
// basic (this surface and every one after it), DAR (decenter and return: this surface
// only), BEN (bend: the coordinate system after the surface is tilted once more, a fold), REV
// (reverse: the basic decenter's operations in reverse order with their signs reversed, tilts
// about z, y, x first and then the shift, so that the values of a basic decenter given again
// with REV on a later surface restore the coordinates before it).
struct Decenter {
    enum class Type { Basic, DecenterAndReturn, Bend, Reverse };
    Type type = Type::Basic;
    double x = 0.0, y = 0.0, z = 0.0, alpha = 0.0, beta = 0.0, gamma = 0.0;
    bool given() const {
        return x != 0.0 || y != 0.0 || z != 0.0 || alpha != 0.0 || beta != 0.0 || gamma != 0.0;
    }
};

struct SurfaceInput {
    Surface surface;
    std::optional<Token> glass;  // the glass token, if any
    bool reflect = false;
    Decenter decenter;
};

class CodeVParser {
  public:
    CodeVParser(std::string file, const GlassCatalog& catalog)
        : file_(std::move(file)), catalog_(catalog) {}

    Prescription parse(std::string_view text) {
        const std::vector<Command> commands = lex(text, file_);
        for (const Command& c : commands) dispatch(c);
        if (surfaces_.size() < 2 || !imageSeen_)
            throw ParseError({file_, 1, 1},
                             "not a CODE V lens: it needs SO (the object), S lines and SI (the "
                             "image)");
        if (!rdmSeen_)
            note(Severity::Warning, {file_, 1, 1},
                 "no RDM command: the first number of S, SO and SI is read as a radius (CODE "
                 "V's radius mode); a file in curvature mode starts with RDM N");
        resolveGlasses();
        convertUnits();
        buildSystem();
        std::stable_sort(
            report_.begin(), report_.end(),
            [](const ImportNote& a, const ImportNote& b) { return a.loc.line < b.loc.line; });
        rx_.report = std::move(report_);
        rx_.sourceFile = file_;
        buildSurfaces();
        rx_.assignNames();
        rx_.validate();
        rx_.notePlausibility();
        return std::move(rx_);
    }

  private:
    void note(Severity s, const FileLoc& loc, const std::string& message,
              ImportNote::Topic topic = ImportNote::Topic::General,
              const std::string& subject = {}) {
        report_.push_back({s, loc, message, topic, subject});
    }
    // Info notes once per command code, with the number of times it was seen.
    void ignored(const Command& c, const std::string& why) {
        const std::string code = upper(c.code().text);
        auto [it, fresh] = ignoredCount_.try_emplace(code, 0);
        ++it->second;
        if (fresh) {
            ignoredNote_[code] = report_.size();
            note(Severity::Info, c.code().loc, code + ": " + why);
        } else {
            ImportNote& n = report_[ignoredNote_[code]];
            const size_t cut = n.message.find(" (seen ");
            n.message =
                n.message.substr(0, cut) + " (seen " + std::to_string(it->second) + " times)";
        }
    }

    SurfaceInput& current(const Command& c) {
        if (surfaces_.empty())
            throw ParseError(c.code().loc, upper(c.code().text) +
                                               " before any surface: it modifies the surface "
                                               "defined by the S line above it");
        return surfaces_.back();
    }

    // An optional surface qualifier (S3, SO, SI) after the code: the surface it names, and the
    // index of the first data token.
    std::pair<SurfaceInput*, size_t> target(const Command& c) {
        if (c.tokens.size() > 1 && !c.tokens[1].quoted) {
            const std::string q = upper(c.tokens[1].text);
            if (q == "SO") {
                current(c);  // an error when there is no surface yet
                return {&surfaces_.front(), 2};
            }
            if (q == "SI") {
                if (!imageSeen_) throw ParseError(c.tokens[1].loc, "SI: no image surface yet");
                return {&surfaces_.back(), 2};
            }
            if (q.size() > 1 && q[0] == 'S' &&
                std::all_of(q.begin() + 1, q.end(), [](char ch) { return std::isdigit(ch); })) {
                const size_t n = std::stoul(q.substr(1));
                if (n >= surfaces_.size())
                    throw ParseError(c.tokens[1].loc, q + ": no such surface yet");
                return {&surfaces_[n], 2};
            }
        }
        return {&current(c), 1};
    }

    const Token& arg(const Command& c, size_t i, const std::string& what) {
        if (i >= c.tokens.size())
            throw ParseError(c.code().loc, upper(c.code().text) + ": missing " + what);
        return c.tokens[i];
    }

    std::vector<double> numbers(const Command& c, size_t first = 1) {
        std::vector<double> v;
        for (size_t i = first; i < c.tokens.size(); ++i)
            v.push_back(number(c.tokens[i], upper(c.code().text) + " value"));
        if (v.empty()) throw ParseError(c.code().loc, upper(c.code().text) + ": no values");
        return v;
    }

    // S, SO, SI: r (or c in curvature mode), t, then optionally the glass and the refract mode.
    void surfaceLine(const Command& c, const std::string& code) {
        SurfaceInput in;
        in.surface.origin = c.code().loc;
        const double first = number(arg(c, 1, "radius"), code + " radius");
        in.surface.curvature = radiusMode_ ? (first == 0.0 ? 0.0 : 1.0 / first) : first;
        if (c.tokens.size() > 2) {
            // The object distance may be written INF (as some exporters do): infinity, as
            // 1e10 lens units and more are.
            const std::string t = upper(c.tokens[2].text);
            in.surface.thicknessMm = code == "SO" && (t == "INF" || t == "INFINITY")
                                         ? kInfinity
                                         : number(c.tokens[2], code + " thickness");
        }
        if (c.tokens.size() > 3) {
            if (upper(c.tokens[3].text) == "REFL")
                in.reflect = true;
            else if (upper(c.tokens[3].text) != "AIR")
                in.glass = c.tokens[3];
        }
        if (c.tokens.size() > 4) {
            const std::string mode = upper(c.tokens[4].text);
            if (mode == "REFL")
                in.reflect = true;
            else if (mode != "REFR")
                note(Severity::Warning, c.tokens[4].loc,
                     code + ": refract mode " + c.tokens[4].text + " is not imported");
        }
        if (code == "SO") {
            if (!surfaces_.empty())
                throw ParseError(c.code().loc, "SO: the object surface is given twice");
            // Distances of 1e10 lens units and more stand for infinity.
            if (std::abs(in.surface.thicknessMm) >= 1e10) in.surface.thicknessMm = kInfinity;
        } else {
            if (surfaces_.empty())
                throw ParseError(c.code().loc, code + " before SO: the object surface comes first");
            if (imageSeen_) throw ParseError(c.code().loc, code + " after SI (the image surface)");
        }
        if (code == "SI") {
            // The thickness of SI is a defocus from where the previous thickness puts it.
            surfaces_.back().surface.thicknessMm += in.surface.thicknessMm;
            in.surface.thicknessMm = 0.0;
            imageSeen_ = true;
        }
        surfaces_.push_back(std::move(in));
    }

    void unsupportedSurface(const Command& c, const std::string& what) {
        current(c);  // a profile before any surface is an error at its line
        // By index: the vector of surfaces grows, so addresses of earlier ones do not last.
        if (unsupportedSurfaces_.insert(surfaces_.size() - 1).second)
            note(Severity::Error, c.code().loc,
                 what + " is not supported by veil (surface " +
                     std::to_string(surfaces_.size() - 1) + "): read as a sphere it would lose " +
                     "its shape");
    }

    void fields(const Command& c, SystemData::FieldKind kind, bool x) {
        if (fieldKind_ && *fieldKind_ != kind)
            throw ParseError(c.code().loc, upper(c.code().text) +
                                               ": fields of another kind were given before; "
                                               "give one kind (XAN/YAN, XOB/YOB, XIM/YIM or "
                                               "XRI/YRI)");
        fieldKind_ = kind;
        (x ? fieldX_ : fieldY_) = numbers(c);
        if (!fieldLoc_.line) fieldLoc_ = c.code().loc;
    }

    void dispatch(const Command& c) {
        const Token& codeToken = c.code();
        const std::string full = upper(codeToken.text);
        // Inside a private catalog block (PRV ... END), its wavelengths and glasses.
        if (inPrivate_) {
            if (!codeToken.quoted && full.rfind("END", 0) == 0) {
                inPrivate_ = false;
            } else if (!codeToken.quoted && full == "PWL") {
                privateWavelengths_ = numbers(c);
            } else if (codeToken.quoted) {
                // 'NAME' n1 n2 ...: the indices at the PWL wavelengths.
                const bool formula = c.tokens.size() > 1 && !parseNumber(c.tokens[1].text);
                if (privateWavelengths_.empty() && !formula)
                    throw ParseError(codeToken.loc, "private glass '" + codeToken.text +
                                                        "' comes before its wavelengths (PWL)");
                // Or a formula: LAU, Laurent's n^2 = A0 + A1 l^2 + A2 l^-2 + ... + A5 l^-8
                // (l in um), the Schott formula.
                if (c.tokens.size() > 1 && !parseNumber(c.tokens[1].text)) {
                    const std::string form = upper(c.tokens[1].text);
                    if (form != "LAU")
                        throw ParseError(c.tokens[1].loc,
                                         "private glass '" + codeToken.text + "' is given by " +
                                             form +
                                             ", which veil does not read (an index table after "
                                             "PWL, or LAU coefficients)");
                    std::vector<double> coefficients = numbers(c, 2);
                    try {
                        Glass::withFormula(codeToken.text, DispersionFormula::Schott, coefficients);
                    } catch (const std::invalid_argument& e) {
                        throw ParseError(c.tokens[1].loc, "private glass '" + codeToken.text +
                                                              "', LAU: " + e.what());
                    }
                    Material m = Material::withFormula(codeToken.text, DispersionFormula::Schott,
                                                       std::move(coefficients));
                    privateGlasses_[normalized(codeToken.text)] = std::move(m);
                    return;
                }
                const std::vector<double> indices = numbers(c);
                if (indices.size() != privateWavelengths_.size())
                    throw ParseError(codeToken.loc,
                                     "private glass '" + codeToken.text + "' gives " +
                                         std::to_string(indices.size()) + " indices for the " +
                                         std::to_string(privateWavelengths_.size()) +
                                         " wavelengths of PWL");
                try {
                    Glass::table(codeToken.text, privateWavelengths_, indices);
                } catch (const std::invalid_argument& e) {
                    throw ParseError(codeToken.loc,
                                     "private glass '" + codeToken.text + "': " + e.what());
                }
                privateGlasses_[normalized(codeToken.text)] =
                    Material::table(codeToken.text, privateWavelengths_, indices);
            } else {
                note(Severity::Warning, codeToken.loc,
                     full + " inside a private glass catalog (PRV ... END): skipped");
            }
            return;
        }
        if (codeToken.quoted) {
            note(Severity::Warning, codeToken.loc,
                 "quoted text '" + codeToken.text + "' where a command was expected: skipped");
            return;
        }
        if (full == "S" || full == "SO" || full == "SI") return surfaceLine(c, full);
        // The asphere coefficients A..J (no I) and the conic K.
        static const std::string kLetters = "ABCDEFGHJ";
        if (full.size() == 1 && kLetters.find(full[0]) != std::string::npos) {
            auto [s, i] = target(c);
            const size_t order = kLetters.find(full[0]) + 1;  // A: r^4 = asphere[1]
            s->surface.asphere[order] = number(arg(c, i, "coefficient"), full);
            return;
        }
        if (full == "K") {
            auto [s, i] = target(c);
            s->surface.conic = number(arg(c, i, "conic constant"), "K");
            return;
        }
        if (full == "WL") {
            wavelengths_ = numbers(c);
            return;
        }
        if (full == "GO" || full == "LEN" || full == "NEW") return;
        if (full == "NA") {
            note(Severity::Error, codeToken.loc,
                 "NA (image-space numerical aperture) is not supported: give EPD, FNO or NAO");
            return;
        }
        // Variable codes: AC, BC, ..., KC (the asphere letters and K), CCY, THC, GLC.
        if (full.size() == 2 && full[1] == 'C' &&
            (kLetters + "K").find(full[0]) != std::string::npos)
            return ignored(c, "a variable code for optimization (not lens data)");
        const std::string code = full.substr(0, 3);
        if (systemCommand(c, code)) return;
        if (surfaceCommand(c, code, full)) return;
        otherCommand(c, code, full);
    }

    // System data: units, aperture, wavelengths' reference and weights, fields.
    bool systemCommand(const Command& c, const std::string& code) {
        const Token& codeToken = c.code();
        if (code == "RDM") {
            rdmSeen_ = true;
            radiusMode_ = !(c.tokens.size() > 1 && upper(c.tokens[1].text).rfind("N", 0) == 0);
        } else if (code == "TIT") {
            rx_.system.name = c.tokens.size() > 1 ? c.tokens[1].text : "";
        } else if (code == "INI") {
            // the designer's initials
        } else if (code == "DIM") {
            const std::string u = upper(arg(c, 1, "unit").text);
            if (u == "M" || u == "MM")
                unit_ = 1.0;
            else if (u == "C" || u == "CM")
                unit_ = 10.0;
            else if (u == "I" || u == "IN")
                unit_ = 25.4;
            else
                throw ParseError(c.tokens[1].loc,
                                 "DIM: unknown unit '" + c.tokens[1].text + "' (M, C or I)");
        } else if (code == "EPD" || code == "FNO" || code == "NAO") {
            const double v = number(arg(c, 1, "value"), code);
            aperture_ = {code == "EPD"   ? SystemAperture::Kind::EntrancePupilDiameter
                         : code == "FNO" ? SystemAperture::Kind::ImageSpaceFNumber
                                         : SystemAperture::Kind::ObjectSpaceNA,
                         v};
        } else if (code == "REF") {
            reference_ = static_cast<int>(number(arg(c, 1, "index"), "REF"));
            referenceLoc_ = codeToken.loc;
        } else if (code == "WTW") {
            wavelengthWeights_ = numbers(c);
        } else if (code == "XAN" || code == "YAN") {
            fields(c, SystemData::FieldKind::AngleDeg, code[0] == 'X');
        } else if (code == "XOB" || code == "YOB") {
            fields(c, SystemData::FieldKind::ObjectHeightMm, code[0] == 'X');
        } else if (code == "XIM" || code == "YIM") {
            fields(c, SystemData::FieldKind::ParaxialImageHeightMm, code[0] == 'X');
        } else if (code == "XRI" || code == "YRI") {
            fields(c, SystemData::FieldKind::RealImageHeightMm, code[0] == 'X');
        } else if (code == "WTF") {
            fieldWeights_ = numbers(c);
        } else if (code == "VUX" || code == "VLX" || code == "VUY" || code == "VLY") {
            vignetting_[code] = numbers(c);
        } else {
            return false;
        }
        return true;
    }

    // Surface data, on the surface the command names (or the current one).
    bool surfaceCommand(const Command& c, const std::string& code, const std::string& full) {
        const Token& codeToken = c.code();
        if (code == "STO") {
            auto [s, i] = target(c);
            (void)i;
            for (SurfaceInput& x : surfaces_) x.surface.stop = false;
            s->surface.stop = true;
        } else if (code == "RDY" || code == "CUY") {
            auto [s, i] = target(c);
            const double v = number(arg(c, i, "value"), code);
            s->surface.curvature = code == "CUY" ? v : (v == 0.0 ? 0.0 : 1.0 / v);
        } else if (code == "THI") {
            auto [s, i] = target(c);
            const Token& t = arg(c, i, "thickness");
            if (parseNumber(t.text))
                s->surface.thicknessMm = number(t, "THI");
            else
                ignored(c, "a thickness solve; the thickness on the S line is used");
        } else if (code == "GLA") {
            auto [s, i] = target(c);
            const Token& g = arg(c, i, "glass");
            s->reflect = upper(g.text) == "REFL";
            if (!s->reflect) s->glass = g;
        } else if (code == "RMD") {
            auto [s, i] = target(c);
            s->reflect = upper(arg(c, i, "mode").text) == "REFL";
        } else if (code == "CIR") {
            auto [s, i] = target(c);
            std::string kind = "CLR";
            while (i < c.tokens.size() && !parseNumber(c.tokens[i].text)) {
                const std::string q = upper(c.tokens[i].text);
                if (q == "CLR" || q == "EDG" || q == "OBS" || q == "HOL") kind = q;
                ++i;  // an aperture label L'A' or a zoom qualifier
            }
            const double r = number(arg(c, i, "radius"), "CIR");
            if (kind == "CLR")
                s->surface.clearSemiDiameterMm = r;
            else if (kind == "EDG")
                s->surface.mechSemiDiameterMm = r;
            else
                s->surface.innerSemiDiameterMm = r;  // a central hole or obscuration
        } else if (code == "SLB") {
            current(c).surface.comment = c.tokens.size() > 1 ? c.tokens[1].text : "";
        } else if (code == "ASP" || code == "CON" || code == "SPH" || code == "CUF") {
            // The profile follows from K and A..J.
        } else if (code == "CCY" || code == "THC" || code == "GLC") {
            ignored(c, "a variable code for optimization (not lens data)");
        } else if (code == "PIM" || code == "PIK") {
            ignored(c, "a solve or pickup; the values on the S lines are used");
        } else if (code == "XDE" || code == "YDE" || code == "ZDE" || code == "ADE" ||
                   code == "BDE" || code == "CDE") {
            auto [s, i] = target(c);
            if (s == surfaces_.data())
                throw ParseError(codeToken.loc, code + ": the object surface cannot be decentered");
            const double v = number(arg(c, i, "value"), code);
            Decenter& d = s->decenter;
            (code == "XDE"   ? d.x
             : code == "YDE" ? d.y
             : code == "ZDE" ? d.z
             : code == "ADE" ? d.alpha
             : code == "BDE" ? d.beta
                             : d.gamma) = v;
        } else if (code == "DAR" || code == "BEN" || code == "REV") {
            auto [s, i] = target(c);
            (void)i;
            s->decenter.type = code == "DAR"   ? Decenter::Type::DecenterAndReturn
                               : code == "BEN" ? Decenter::Type::Bend
                                               : Decenter::Type::Reverse;
        } else {
            return false;
        }
        return true;
    }

    // What veil does not import: said in the report, or an error where it would change the
    // lens.
    void otherCommand(const Command& c, const std::string& code, const std::string& full) {
        const Token& codeToken = c.code();
        if (code == "RET") {
            auto [s, i] = target(c);
            (void)i;
            note(Severity::Error, codeToken.loc,
                 "RET (return to a surface's coordinates) is not supported by veil (surface " +
                     std::to_string(s - surfaces_.data()) +
                     "): only basic decenters, DAR, BEN and REV");
        } else if (code == "XTO" || code == "YTO" || code == "AAS" || code == "CYL" ||
                   code == "SPS" || code == "RDX" || code == "CUX") {
            unsupportedSurface(c, "surface profile " + full);
        } else if (code == "DIF" || code == "HOR" || code == "HWL" || code == "HCT" ||
                   code == "HCO" || code == "HCC") {
            unsupportedSurface(c, "a diffractive surface (" + full + ")");
        } else if (code == "REX" || code == "REY" || code == "ELX" || code == "ELY" ||
                   code == "ADX" || code == "ADY" || code == "ARO") {
            note(Severity::Warning, codeToken.loc,
                 full +
                     ": rectangular, elliptical and decentered apertures are not imported "
                     "(only CIR limits rays)");
        } else if (code == "PRV") {
            inPrivate_ = true;
        } else if (code == "ZOO") {
            note(Severity::Error, codeToken.loc,
                 "ZOO: zoom and multiple positions are not supported by veil");
        } else if (code == "TEM" || code == "PRE") {
            ignored(c,
                    "temperature and pressure are not imported (the catalog indices at 20 "
                    "C and 1 atm are used)");
        } else if (code == "DER" || code == "CLS" || code == "POL" || code == "WID" ||
                   code == "CA" || code == "UID" || code == "DOR") {
            ignored(c, "display or analysis data");
        } else {
            note(Severity::Warning, codeToken.loc,
                 "unknown command '" + codeToken.text + "': skipped",
                 ImportNote::Topic::UnknownCommand,
                 codeToken.text + " (line " + std::to_string(codeToken.loc.line) + ")");
        }
    }

    // The glass of every surface: REFL, numbers (glass codes), nd:vd, catalog names.
    void resolveGlasses() {
        for (size_t i = 0; i < surfaces_.size(); ++i) {
            SurfaceInput& in = surfaces_[i];
            Surface& s = in.surface;
            if (in.reflect) {
                s.mirror = true;
                s.material = i > 0 ? surfaces_[i - 1].surface.material : Material::air();
                continue;
            }
            if (!in.glass) {
                s.material = Material::air();
                continue;
            }
            const Token& g = *in.glass;
            if (const auto colon = g.text.find(':'); colon != std::string::npos) {
                const auto nd = parseNumber(g.text.substr(0, colon));
                const auto vd = parseNumber(g.text.substr(colon + 1));
                if (!nd || !vd || *nd < 1.0 || *vd < 0.0)
                    throw ParseError(g.loc, "glass '" + g.text + "': nd:vd needs nd >= 1, vd >= 0");
                s.material = Material::model(*nd, *vd);
                continue;
            }
            if (parseNumber(g.text) && !g.quoted) {
                s.material = glassCode(g);
                continue;
            }
            s.material = catalogGlass(g);
        }
    }

    // CODE V's numeric glass: a six-digit code nnnvvv (nd 1.nnn, vd vv.v), or nnn...vvv...
    // (the integer digits are the decimals of nd - 1, the fraction x 100 is vd).
    Material glassCode(const Token& g) {
        const std::string& t = g.text;
        const size_t dot = t.find('.');
        const std::string whole = t.substr(0, dot);
        if (whole.empty() ||
            !std::all_of(whole.begin(), whole.end(), [](char c) { return std::isdigit(c); }))
            throw ParseError(g.loc, "glass '" + t + "' is not a glass code");
        if (dot == std::string::npos) {
            if (whole.size() != 6)
                throw ParseError(g.loc, "glass '" + t +
                                            "': a glass code without a point has six digits "
                                            "(nnnvvv: nd 1.nnn, vd vv.v)");
            return Material::model(1.0 + std::stod(whole.substr(0, 3)) / 1000.0,
                                   std::stod(whole.substr(3)) / 10.0);
        }
        const std::string frac = t.substr(dot + 1);
        const double nd =
            1.0 + std::stod(whole) / std::pow(10.0, static_cast<double>(whole.size()));
        const double vd = frac.empty() ? 0.0 : std::stod("0." + frac) * 100.0;
        if (!(vd > 0.0))
            throw ParseError(g.loc, "glass code '" + t +
                                        "' gives vd = 0: the fraction after the point is vd / 100 "
                                        "(517000.520000 is nd 1.517, vd 52)");
        return Material::model(nd, vd);
    }

    Material catalogGlass(const Token& g) {
        // A private glass (PRV) is the lens's own: it comes before any catalog's.
        if (auto it = privateGlasses_.find(normalized(g.text)); it != privateGlasses_.end())
            return it->second;
        std::string name = g.text, vendor;
        if (const size_t us = name.rfind('_'); us != std::string::npos && us > 0) {
            vendor = upper(name.substr(us + 1));
            name = name.substr(0, us);
        }
        const std::vector<std::string> preferred =
            vendor.empty() ? std::vector<std::string>{} : std::vector<std::string>{vendor};
        if (const Glass* glass = catalog_.find(name, preferred))
            return Material::catalog(glass->name());
        // CODE V drops the punctuation of the maker's name (NBK7 for N-BK7): compare without it,
        // the vendor's catalog first.
        const std::string key = normalized(name);
        std::vector<std::string> order = preferred;
        for (const std::string& c : catalog_.catalogNames())
            if (upper(c) != vendor) order.push_back(c);
        for (const std::string& c : order)
            for (const Glass* glass : catalog_.glasses(c))
                if (normalized(glass->name()) == key) {
                    if (!vendor.empty() && upper(glass->catalog()) != vendor)
                        note(Severity::Info, g.loc,
                             "glass " + g.text + " taken from " + glass->catalog() +
                                 " (no catalog " + vendor + " has it)");
                    return Material::catalog(glass->name());
                }
        if (const Glass* glass = catalog_.findSuccessor(name, preferred)) {
            note(Severity::Info, g.loc,
                 "glass " + g.text + " is in no loaded catalog under that name; taken as " +
                     glass->name() + " (" + glass->catalog() + "), the glass the name denotes",
                 ImportNote::Topic::Glass);
            return Material::catalog(glass->name());
        }
        std::string msg = "unknown glass '" + g.text + "'";
        msg +=
            ": not found in any catalog veil has loaded, nor in the file's private glasses (PRV)";
        const auto suggestions = catalog_.suggestions(name);
        if (!suggestions.empty()) {
            msg += " (did you mean ";
            for (size_t k = 0; k < suggestions.size(); ++k) msg += (k ? ", " : "") + suggestions[k];
            msg += "?)";
        }
        msg += "; load its catalog with --glass-catalog FILE.agf";
        note(Severity::Error, g.loc, msg, ImportNote::Topic::Glass);
        return Material::catalog(g.text);
    }

    // The prescription's surfaces: each decentered surface gets coordinate breaks
    // (CoordinateBreak, docs/format.md) around it. Basic: a break before it, which moves it
    // and every surface after it (ZDE lengthens the gap before). DAR: the same break before
    // it and its inverse after it, which carries its thickness, measured from the returned
    // (undecentered) vertex. BEN: after the surface a break that tilts once more, as a fold.
    // REV: before it the break that undoes a basic decenter of the same values (every value
    // negated, tilts first), and the shift along z, negated too, after the tilts: a distance
    // from that break to the surface.
    void buildSurfaces() {
        for (size_t i = 0; i < surfaces_.size(); ++i) {
            Surface s = std::move(surfaces_[i].surface);
            const Decenter& d = surfaces_[i].decenter;
            if (i == 0 || !d.given()) {
                rx_.surfaces.push_back(std::move(s));
                continue;
            }
            if (d.type == Decenter::Type::Reverse) {
                Surface in;
                in.coordinateBreak = CoordinateBreak{-d.x, -d.y, -d.alpha, -d.beta, -d.gamma, true};
                in.thicknessMm = -d.z;
                in.material = rx_.surfaces.back().material;
                in.origin = s.origin;
                in.comment = "reverse decenter (REV) of the next surface";
                rx_.surfaces.push_back(std::move(in));
                rx_.surfaces.push_back(std::move(s));
                continue;
            }
            Surface& before = rx_.surfaces.back();
            if (std::isfinite(before.thicknessMm)) before.thicknessMm += d.z;
            Surface in;
            in.coordinateBreak = CoordinateBreak{d.x, d.y, d.alpha, d.beta, d.gamma, false};
            in.material = before.material;
            in.origin = s.origin;
            in.comment = "decenter of the next surface";
            rx_.surfaces.push_back(std::move(in));
            // Nothing follows the image: DAR and BEN on it are basic decenters.
            if (d.type == Decenter::Type::Basic || i + 1 == surfaces_.size()) {
                rx_.surfaces.push_back(std::move(s));
                continue;
            }
            Surface out;
            out.coordinateBreak =
                d.type == Decenter::Type::DecenterAndReturn
                    ? CoordinateBreak{-d.x, -d.y, -d.alpha, -d.beta, -d.gamma, true}
                    : CoordinateBreak{0.0, 0.0, d.alpha, d.beta, d.gamma, false};
            out.thicknessMm =
                s.thicknessMm - (d.type == Decenter::Type::DecenterAndReturn ? d.z : 0.0);
            out.material = s.material;
            out.origin = s.origin;
            out.comment = d.type == Decenter::Type::DecenterAndReturn ? "return (DAR)"
                                                                       : "bend (BEN)";
            s.thicknessMm = 0.0;
            rx_.surfaces.push_back(std::move(s));
            rx_.surfaces.push_back(std::move(out));
        }
    }

    void convertUnits() {
        const double u = unit_;
        for (SurfaceInput& in : surfaces_) {
            Surface& s = in.surface;
            in.decenter.x *= u;
            in.decenter.y *= u;
            in.decenter.z *= u;
            s.curvature /= u;
            if (std::isfinite(s.thicknessMm)) s.thicknessMm *= u;
            s.clearSemiDiameterMm *= u;
            s.mechSemiDiameterMm *= u;
            s.innerSemiDiameterMm *= u;
            for (size_t k = 0; k < s.asphere.size(); ++k)
                s.asphere[k] *= std::pow(u, 1.0 - static_cast<double>(2 * k + 2));
        }
        if (aperture_ && aperture_->kind == SystemAperture::Kind::EntrancePupilDiameter)
            aperture_->value *= u;
        if (fieldKind_ && *fieldKind_ != SystemData::FieldKind::AngleDeg) {
            for (double& v : fieldX_) v *= u;
            for (double& v : fieldY_) v *= u;
        }
    }

    void buildSystem() {
        SystemData& sys = rx_.system;
        // Wavelengths, in file order; REF names the primary (1-based).
        if (wavelengths_.empty()) {
            wavelengths_ = {587.5618};
            note(Severity::Warning, {file_, 1, 1}, "no WL: the d line (587.5618 nm) is used");
        }
        for (size_t i = 0; i < wavelengths_.size(); ++i)
            sys.wavelengths.push_back(
                {wavelengths_[i], i < wavelengthWeights_.size() ? wavelengthWeights_[i] : 1.0});
        if (reference_ < 1 || reference_ > static_cast<int>(wavelengths_.size()))
            throw ParseError(referenceLoc_.line ? referenceLoc_ : FileLoc{file_, 1, 1},
                             "REF " + std::to_string(reference_) + ": there are " +
                                 std::to_string(wavelengths_.size()) + " wavelengths");
        sys.primaryWavelength = reference_ - 1;
        // Fields.
        sys.fieldKind = fieldKind_.value_or(SystemData::FieldKind::AngleDeg);
        const size_t n = std::max({fieldX_.size(), fieldY_.size(), size_t(1)});
        if ((!fieldX_.empty() && fieldX_.size() != n) || (!fieldY_.empty() && fieldY_.size() != n))
            throw ParseError(fieldLoc_, "the x and y field lists have different lengths");
        for (size_t i = 0; i < n; ++i) {
            Field f{i < fieldX_.size() ? fieldX_[i] : 0.0, i < fieldY_.size() ? fieldY_[i] : 0.0,
                    i < fieldWeights_.size() ? fieldWeights_[i] : 1.0};
            // Upper and lower factors cut the pupil to [-(1 - VL), 1 - VU]: its centre and
            // half width.
            auto factor = [&](const char* code) {
                const auto it = vignetting_.find(code);
                return it != vignetting_.end() && i < it->second.size() ? it->second[i] : 0.0;
            };
            f.vdx = 0.5 * (factor("VLX") - factor("VUX"));
            f.vcx = 0.5 * (factor("VLX") + factor("VUX"));
            f.vdy = 0.5 * (factor("VLY") - factor("VUY"));
            f.vcy = 0.5 * (factor("VLY") + factor("VUY"));
            sys.fields.push_back(f);
        }
        if (sys.fieldKind == SystemData::FieldKind::ObjectHeightMm &&
            std::isinf(surfaces_[0].surface.thicknessMm))
            throw ParseError(fieldLoc_,
                             "XOB/YOB give object heights, which need a finite object distance");
        // The aperture; the stop is surface 1 when no STO names it.
        if (!aperture_) {
            note(Severity::Error, {file_, 1, 1}, "no system aperture: give EPD, FNO or NAO");
            aperture_ = {SystemAperture::Kind::EntrancePupilDiameter, 1.0};
        }
        sys.aperture = *aperture_;
        if (std::none_of(surfaces_.begin(), surfaces_.end(),
                         [](const SurfaceInput& s) { return s.surface.stop; })) {
            surfaces_[1].surface.stop = true;
            note(Severity::Info, surfaces_[1].surface.origin,
                 "no STO: surface 1 is the aperture stop");
        }
    }

    std::string file_;
    const GlassCatalog& catalog_;
    Prescription rx_;
    std::vector<ImportNote> report_;
    std::map<std::string, int> ignoredCount_;
    std::map<std::string, size_t> ignoredNote_;
    std::vector<SurfaceInput> surfaces_;
    std::set<size_t> unsupportedSurfaces_;  // indices already reported
    bool imageSeen_ = false;
    bool rdmSeen_ = false;
    bool radiusMode_ = true;
    bool inPrivate_ = false;
    std::vector<double> privateWavelengths_;          // PWL, nm
    std::map<std::string, Material> privateGlasses_;  // by normalized name
    double unit_ = 1.0;
    std::optional<SystemAperture> aperture_;
    std::vector<double> wavelengths_, wavelengthWeights_;
    int reference_ = 1;
    FileLoc referenceLoc_;
    std::optional<SystemData::FieldKind> fieldKind_;
    std::vector<double> fieldX_, fieldY_, fieldWeights_;
    std::map<std::string, std::vector<double>> vignetting_;  // VUX, VLX, VUY, VLY per field
    FileLoc fieldLoc_;
};

}  // namespace

Prescription readCodeVText(std::string_view bytes, const std::string& fileName,
                           const GlassCatalog& catalog) {
    const std::string decoded = decodeText(bytes, fileName);
    return CodeVParser(fileName, catalog).parse(decoded);
}

Prescription readCodeV(const std::filesystem::path& path, const GlassCatalog& catalog) {
    const std::optional<std::string> bytes = readInputFile(path);
    if (!bytes) throw ParseError({path.string(), 0, 0}, "cannot read the file");
    return readCodeVText(*bytes, path.string(), catalog);
}

}  // namespace veil
