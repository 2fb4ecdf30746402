// Zemax .zmx import. User documentation: docs/zmx-import.md; overview in zmx_reader.h.
//
// The reader works in three passes over the decoded text:
//   1. split lines into whitespace-separated tokens (a "quoted string" is one token), each
//      with its 1-based column;
//   2. dispatch every line on its command tag, filling surfaces in file units and collecting
//      header data (fields, wavelengths, aperture, units) and glass references;
//   3. resolve glasses against the catalog (the file's GCAT order first), give mirrors the
//      incident medium, import centred circular holes (CLAP, OBSC), convert lengths to mm,
//      assemble fields and wavelengths, and add the summary notes. Then
//      Prescription::assignNames() and validate().

#include "lensdata/zmx_reader.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "lensdata/glass_catalog.h"
#include "lensdata/input_file.h"
#include "lensdata/prescription.h"
#include "lensdata/text_decoding.h"

namespace veil {

namespace {

// The most an index relative to air may lie below 1 and still be read as air: a gas or vacuum
// (vacuum relative to air at 20 C and 1 atm is 0.99973).
constexpr double kGasIndexBelowAir = 1e-3;

// Tokens and Lines

struct Token {
    std::string_view text;  // without the quotes of a "quoted" token
    size_t offset = 0;      // byte offset in the line, of the opening quote if quoted
    bool quoted = false;
};

struct Line {
    int number = 0;
    std::string_view text;
    std::vector<Token> tokens;
};

std::vector<Token> tokenize(std::string_view text) {
    std::vector<Token> out;
    size_t i = 0;
    auto isSpace = [](char c) { return c == ' ' || c == '\t' || c == '\f' || c == '\v'; };
    while (i < text.size()) {
        while (i < text.size() && isSpace(text[i])) ++i;
        if (i >= text.size()) break;
        Token t;
        t.offset = i;
        if (text[i] == '"') {
            const size_t close = text.find('"', i + 1);
            const size_t end = close == std::string_view::npos ? text.size() : close;
            t.text = text.substr(i + 1, end - i - 1);
            t.quoted = true;
            i = close == std::string_view::npos ? text.size() : close + 1;
        } else {
            const size_t start = i;
            while (i < text.size() && !isSpace(text[i])) ++i;
            t.text = text.substr(start, i - start);
        }
        out.push_back(t);
    }
    return out;
}

std::vector<Line> splitLines(std::string_view text) {
    std::vector<Line> out;
    int number = 1;
    size_t start = 0;
    while (start <= text.size()) {
        size_t end = text.find_first_of("\r\n", start);
        if (end == std::string_view::npos) end = text.size();
        Line line;
        line.number = number++;
        line.text = text.substr(start, end - start);
        line.tokens = tokenize(line.text);
        if (!line.tokens.empty()) out.push_back(std::move(line));
        if (end == text.size()) break;
        // CR LF, LF and lone CR all end a line.
        start =
            end + ((text[end] == '\r' && end + 1 < text.size() && text[end + 1] == '\n') ? 2 : 1);
    }
    return out;
}

std::string upper(std::string_view s) {
    std::string out(s);
    for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return out;
}

std::string trim(std::string_view s) {
    const auto b = s.find_first_not_of(" \t");
    if (b == std::string_view::npos) return {};
    const auto e = s.find_last_not_of(" \t");
    return std::string(s.substr(b, e - b + 1));
}

std::string formatNumber(double v) {
    std::ostringstream os;
    os.precision(10);
    os << v;
    return os.str();
}

std::string joinNames(const std::vector<std::string>& names) {
    std::string out;
    for (size_t i = 0; i < names.size(); ++i) out += (i ? ", " : "") + names[i];
    return out;
}

// Commands that only concern display, solves, optimization, tolerancing or analysis settings.
// They do not change the surfaces the reader imports (solves and pickups are already evaluated
// in the values the file stores), so they are summarized in one Info note per tag.
struct SkippedTag {
    const char* tag;
    const char* meaning;
};
constexpr std::array kSkippedTags = {
    SkippedTag{"VERS", "program version"},
    SkippedTag{"PFIL", "file settings"},
    SkippedTag{"LANG", "user interface language"},
    SkippedTag{"GFAC", "glass substitution settings"},
    SkippedTag{"RAIM", "ray aiming settings"},
    SkippedTag{"PUSH", "lens push settings"},
    SkippedTag{"SDMA", "semi-diameter margin settings"},
    SkippedTag{"OMMA", "mechanical semi-diameter settings"},
    SkippedTag{"ROPD", "OPD reference settings"},
    SkippedTag{"HYPR", "huygens/analysis settings"},
    SkippedTag{"PICB", "paraxial ignore-coordinate-break setting"},
    SkippedTag{"VANN", "field vignetting angle (clear apertures are used instead)"},
    SkippedTag{"POLS", "polarization analysis settings"},
    SkippedTag{"GLRS", "glass rest settings"},
    SkippedTag{"GSTD", "glass substitution template"},
    SkippedTag{"NSCD", "non-sequential ray trace settings"},
    SkippedTag{"COFN", "coating, scatter and profile data file names"},
    SkippedTag{"TOL", "tolerance data"},
    SkippedTag{"TOLE", "tolerance data"},
    SkippedTag{"MOFF", "multi-configuration operand data"},
    SkippedTag{"MNUM", "configuration count"},
    SkippedTag{"REAY", "merit function operand"},
    SkippedTag{"EFLY", "merit function operand"},
    SkippedTag{"DMFS", "default merit function settings"},
    SkippedTag{"BLNK", "merit function separator"},
    SkippedTag{"OPDX", "OPD settings"},
    SkippedTag{"FIMP", "surface import data"},
    SkippedTag{"HIDE", "surface drawing visibility"},
    SkippedTag{"SLAB", "surface label number"},
    SkippedTag{"POPS", "physical optics settings"},
    SkippedTag{"MIRR", "mirror substrate drawing data (the mirror flag is GLAS MIRROR)"},
    SkippedTag{"PZUP", "thickness pickup (the picked-up thickness in DISZ was imported)"},
    SkippedTag{"FLAP", "floating aperture solve (the semi-diameter in DIAM was imported)"},
    SkippedTag{"MAZH", "thickness solve (the solved thickness in DISZ was imported)"},
};

const SkippedTag* findSkipped(std::string_view tag) {
    for (const SkippedTag& s : kSkippedTags)
        if (tag == s.tag) return &s;
    return nullptr;
}

// The lens unit of a UNIT line and its length in mm.
std::optional<double> mmPerUnit(std::string_view unit) {
    const std::string u = upper(unit);
    if (u == "MM") return 1.0;
    if (u == "CM") return 10.0;
    if (u == "IN" || u == "INCH" || u == "INCHES") return 25.4;
    if (u == "M" || u == "METER" || u == "METERS") return 1000.0;
    return std::nullopt;
}

// Parser

class ZmxParser {
  public:
    ZmxParser(std::string fileName, const GlassCatalog& catalog)
        : file_(std::move(fileName)), catalog_(catalog) {}

    Prescription parse(std::string_view decoded);

  private:
    using Severity = ImportNote::Severity;

    // A GLAS line, resolved after the whole file is read (GCAT may come anywhere).
    struct GlassRef {
        int surface = 0;
        std::string name;
        int solve = 0;
        std::optional<double> nd, vd, dPgF;
        FileLoc loc;
    };
    // nd 1.5, Vd 40 on a catalog glass's line: a placeholder, not the glass's data.
    static bool placeholderGlassData(const GlassRef& g) {
        return g.nd && g.vd && *g.nd == 1.5 && *g.vd == 40.0;
    }
    // A surface whose TYPE is not imported: the note is written when its block ends, so that
    // it can list the parameters that were lost.
    struct UnsupportedSurface {
        std::string type;
        FileLoc loc;
        std::vector<std::string> lostParameters;
    };
    struct TagCount {
        int count = 0;
        FileLoc first;
    };
    // A CLAP (circular aperture, min and max radius) or OBSC (circular obscuration, min and
    // max radius) line, with the OBDC decenter that may follow it; resolved once the glasses
    // are known, since only mirrors and surfaces in air take a hole.
    struct SurfaceApertureRef {
        int surface = 0;
        std::string tag;
        double minRadius = 0.0, maxRadius = 0.0;  // lens units
        double decenterX = 0.0, decenterY = 0.0;
        std::string text;  // the line, for the notes
        FileLoc loc;
    };

    // Positions and values
    FileLoc locOf(const Line& line, size_t byteOffset) const;
    FileLoc locOf(const Line& line) const { return {file_, line.number, 1}; }
    FileLoc locOf(const Line& line, const Token& t) const { return locOf(line, t.offset); }
    const Token& arg(const Line& line, size_t i, const char* what) const;
    double number(const Line& line, size_t i, const char* what) const;
    std::optional<double> optionalNumber(const Line& line, size_t i) const;
    int integer(const Line& line, size_t i, const char* what) const;
    bool isNumber(const Line& line, size_t i) const;  // token i exists and number() takes it
    std::vector<double> numberList(const Line& line) const;
    std::string restOfLine(const Line& line, size_t firstToken) const;

    void note(Severity s, FileLoc loc, std::string message,
              ImportNote::Topic topic = ImportNote::Topic::General, std::string subject = {}) {
        report_.push_back({s, std::move(loc), std::move(message), topic, std::move(subject)});
    }
    void countSolve(const std::string& what, const FileLoc& loc) {
        TagCount& c = solves_[what];
        if (c.count++ == 0) c.first = loc;
    }

    // Commands
    void dispatch(const Line& line);
    bool headerCommand(const std::string& tag, const Line& line);
    bool surfaceCommand(const std::string& tag, const Line& line);
    void typeCommand(const Line& line);
    void parmCommand(const Line& line);
    void xdatCommand(const Line& line);
    void glassCommand(const Line& line);
    bool apertureCommand(const std::string& tag, const Line& line);
    Surface& current(const Line& line, const std::string& tag);
    void endSurface();

    // Post-processing
    void resolveGlasses();
    void applyMirrors();
    void importHoles();
    void convertUnits();
    void buildFields();
    void buildWavelengths();
    void buildAperture();
    void checkApertures();
    void summarize();

    std::string file_;
    const GlassCatalog& catalog_;
    Prescription rx_;
    std::vector<ImportNote> report_;

    // Surfaces
    std::optional<UnsupportedSurface> unsupported_;
    std::vector<std::string> surfaceTypes_;  // TYPE of each surface, upper case
    std::vector<GlassRef> glasses_;
    std::vector<SurfaceApertureRef> surfaceApertures_;

    // Header
    double mmPerUnit_ = 1.0;
    std::string unitName_ = "MM";
    FileLoc unitLoc_;
    std::optional<int> fieldType_;
    FileLoc fieldTypeLoc_;
    std::optional<int> fieldCount_, waveCount_;
    std::vector<double> xFields_, yFields_, fieldWeights_;
    std::array<std::vector<double>, 4> vignetting_;  // VDX, VDY, VCX, VCY per field
    bool oldFieldForm_ = false;
    std::map<int, std::pair<double, double>> wavm_;  // index -> (um, weight)
    std::vector<double> waveList_, waveWeights_;     // WAVL / WAVN and WWGT / WWGN
    FileLoc waveLoc_;
    std::optional<int> primaryWave_;
    FileLoc primaryWaveLoc_;
    struct ApertureLine {
        std::string tag;
        double value = 0.0;
        int flag = 0;
        FileLoc loc;
    };
    std::vector<ApertureLine> apertureLines_;

    // Summaries
    std::map<std::string, TagCount> skipped_;  // known, display-only tags
    // Unknown commands, per tag: how often, the first line and its text.
    std::map<std::string, std::pair<TagCount, std::string>> unknown_;
    // GCAT names no loaded catalog has: a Warning only if a glass is then not found.
    std::vector<std::pair<std::string, FileLoc>> unloadedCatalogs_;
    std::map<std::string, TagCount> solves_;   // solves and pickups on imported values
};

FileLoc ZmxParser::locOf(const Line& line, size_t byteOffset) const {
    // Columns count characters: skip UTF-8 continuation bytes.
    int column = 1;
    for (size_t i = 0; i < byteOffset && i < line.text.size(); ++i)
        if ((static_cast<unsigned char>(line.text[i]) & 0xC0) != 0x80) ++column;
    return {file_, line.number, column};
}

const Token& ZmxParser::arg(const Line& line, size_t i, const char* what) const {
    if (i >= line.tokens.size())
        throw ParseError(locOf(line, line.text.size()),
                         std::string(line.tokens[0].text) + ": missing " + what);
    return line.tokens[i];
}

double ZmxParser::number(const Line& line, size_t i, const char* what) const {
    const Token& t = arg(line, i, what);
    std::string_view s = t.text;
    if (!s.empty() && s[0] == '+') s.remove_prefix(1);
    double v = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (t.quoted || s.empty() || ec != std::errc() || end != s.data() + s.size() ||
        !std::isfinite(v))
        throw ParseError(locOf(line, t), std::string(line.tokens[0].text) + ": malformed " + what +
                                             " '" + std::string(t.text) + "'");
    return v;
}

std::optional<double> ZmxParser::optionalNumber(const Line& line, size_t i) const {
    if (i >= line.tokens.size()) return std::nullopt;
    return number(line, i, "number");
}

bool ZmxParser::isNumber(const Line& line, size_t i) const {
    if (i >= line.tokens.size()) return false;
    try {
        number(line, i, "number");
        return true;
    } catch (const ParseError&) {
        return false;
    }
}

int ZmxParser::integer(const Line& line, size_t i, const char* what) const {
    // Zemax sometimes writes integers as "6.0"; accept integral values.
    const double v = number(line, i, what);
    if (v != std::floor(v) || std::abs(v) > 1e9)
        throw ParseError(locOf(line, line.tokens[i]),
                         std::string(line.tokens[0].text) + ": expected an integer " + what +
                             ", got '" + std::string(line.tokens[i].text) + "'");
    return static_cast<int>(v);
}

std::vector<double> ZmxParser::numberList(const Line& line) const {
    std::vector<double> out;
    for (size_t i = 1; i < line.tokens.size(); ++i) out.push_back(number(line, i, "value"));
    return out;
}

std::string ZmxParser::restOfLine(const Line& line, size_t firstToken) const {
    if (firstToken >= line.tokens.size()) return {};
    std::string s = trim(line.text.substr(line.tokens[firstToken].offset));
    if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
    return s;
}

Surface& ZmxParser::current(const Line& line, const std::string& tag) {
    if (rx_.surfaces.empty())
        throw ParseError(locOf(line), tag + " appears before the first SURF line");
    return rx_.surfaces.back();
}

// Command Dispatch

void ZmxParser::dispatch(const Line& line) {
    const std::string tag(line.tokens[0].text);
    if (tag == "SURF") {
        endSurface();
        const int index = integer(line, 1, "surface number");
        const int expected = static_cast<int>(rx_.surfaces.size());
        if (index != expected)
            note(Severity::Warning, locOf(line, line.tokens[1]),
                 "SURF " + std::to_string(index) + " is surface " + std::to_string(expected) +
                     " in file order; surfaces are numbered in file order");
        Surface s;
        s.origin = locOf(line);
        rx_.surfaces.push_back(std::move(s));
        surfaceTypes_.push_back("STANDARD");
        return;
    }
    if (headerCommand(tag, line)) return;
    if (surfaceCommand(tag, line)) return;
    if (const SkippedTag* s = findSkipped(tag)) {
        TagCount& c = skipped_[s->tag];
        if (c.count++ == 0) c.first = locOf(line);
        return;
    }
    auto& [count, text] = unknown_[tag];
    if (count.count++ == 0) {
        count.first = locOf(line);
        text = trim(line.text);
    }
}

bool ZmxParser::headerCommand(const std::string& tag, const Line& line) {
    SystemData& sys = rx_.system;
    if (tag == "NAME") {
        sys.name = restOfLine(line, 1);
    } else if (tag == "NOTE") {
        // NOTE <index> <text>
        size_t first = 1;
        if (line.tokens.size() > 1 && !line.tokens[1].text.empty() &&
            std::all_of(line.tokens[1].text.begin(), line.tokens[1].text.end(),
                        [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
            first = 2;
        const std::string text = restOfLine(line, first);
        if (!text.empty()) sys.notes += (sys.notes.empty() ? "" : "\n") + text;
    } else if (tag == "MODE") {
        const std::string mode = upper(arg(line, 1, "mode").text);
        if (mode != "SEQ")
            note(Severity::Error, locOf(line, line.tokens[1]),
                 "MODE " + mode +
                     ": only sequential systems are imported; non-sequential objects are "
                     "ignored");
    } else if (tag == "UNIT") {
        const Token& t = arg(line, 1, "lens unit");
        const auto mm = mmPerUnit(t.text);
        if (!mm)
            throw ParseError(locOf(line, t), "UNIT: unknown lens unit '" + std::string(t.text) +
                                                 "' (expected MM, CM, IN or METER)");
        mmPerUnit_ = *mm;
        unitName_ = upper(t.text);
        unitLoc_ = locOf(line);
    } else if (tag == "ENPD" || tag == "FNUM" || tag == "OBNA") {
        ApertureLine a{tag, number(line, 1, "aperture value"), 0, locOf(line)};
        if (line.tokens.size() > 2) a.flag = integer(line, 2, "aperture flag");
        apertureLines_.push_back(a);
    } else if (tag == "FLOA") {
        apertureLines_.push_back({tag, 0.0, 0, locOf(line)});
    } else if (tag == "ENVD") {
        // ENVD <temperature C> <pressure atm> <flag>
        const double temperatureC = number(line, 1, "temperature");
        const double pressureAtm = line.tokens.size() > 2 ? number(line, 2, "pressure") : 1.0;
        if (std::abs(temperatureC - 20.0) > 1e-9 || std::abs(pressureAtm - 1.0) > 1e-9)
            note(Severity::Warning, locOf(line),
                 "environment " + formatNumber(temperatureC) + " C, " + formatNumber(pressureAtm) +
                     " atm ignored: indices are taken at the catalog reference (20 C, 1 atm) "
                     "and no thermal expansion is applied");
    } else if (tag == "GCAT") {
        sys.glassCatalogs.clear();
        const auto known = catalog_.catalogNames();
        for (size_t i = 1; i < line.tokens.size(); ++i) {
            const std::string name = upper(line.tokens[i].text);
            sys.glassCatalogs.push_back(name);
            const bool loaded = std::any_of(known.begin(), known.end(),
                                            [&](const auto& k) { return upper(k) == name; });
            if (!loaded) unloadedCatalogs_.push_back({name, locOf(line, line.tokens[i])});
        }
    } else if (tag == "FTYP") {
        // FTYP <type> <object telecentric> <field count> <wavelength count> <?> <?> <afocal>
        fieldType_ = integer(line, 1, "field type");
        fieldTypeLoc_ = locOf(line, line.tokens[1]);
        if (line.tokens.size() > 2 && integer(line, 2, "telecentric flag") != 0)
            note(Severity::Warning, locOf(line, line.tokens[2]),
                 "object space telecentric is not supported; the pupil is found from the stop");
        if (line.tokens.size() > 3) fieldCount_ = integer(line, 3, "field count");
        if (line.tokens.size() > 4) waveCount_ = integer(line, 4, "wavelength count");
        if (line.tokens.size() > 7 && integer(line, 7, "afocal flag") != 0)
            note(Severity::Warning, locOf(line, line.tokens[7]),
                 "afocal image space is not supported; image data are computed as for a "
                 "focal system");
        for (size_t i = 5; i < std::min<size_t>(line.tokens.size(), 7); ++i)
            if (number(line, i, "value") != 0.0)
                note(Severity::Info, locOf(line, line.tokens[i]),
                     "FTYP entry " + std::to_string(i) + " = " + std::string(line.tokens[i].text) +
                         " is not interpreted");
    } else if (tag == "XFLN" || tag == "XFLD") {
        xFields_ = numberList(line);
        oldFieldForm_ = tag == "XFLD";
    } else if (tag == "YFLN" || tag == "YFLD") {
        yFields_ = numberList(line);
        oldFieldForm_ = tag == "YFLD";
    } else if (tag == "FWGN" || tag == "FWGT") {
        fieldWeights_ = numberList(line);
    } else if (tag == "VDXN") {
        vignetting_[0] = numberList(line);
    } else if (tag == "VDYN") {
        vignetting_[1] = numberList(line);
    } else if (tag == "VCXN") {
        vignetting_[2] = numberList(line);
    } else if (tag == "VCYN") {
        vignetting_[3] = numberList(line);
    } else if (tag == "WAVM") {
        // WAVM <index> <wavelength um> <weight>
        const int index = integer(line, 1, "wavelength index");
        const double um = number(line, 2, "wavelength");
        const double weight = line.tokens.size() > 3 ? number(line, 3, "weight") : 1.0;
        wavm_[index] = {um, weight};
        if (waveLoc_.line == 0) waveLoc_ = locOf(line);
    } else if (tag == "WAVL" || tag == "WAVN") {
        waveList_ = numberList(line);
        waveLoc_ = locOf(line);
    } else if (tag == "WWGT" || tag == "WWGN") {
        waveWeights_ = numberList(line);
    } else if (tag == "PWAV") {
        primaryWave_ = integer(line, 1, "primary wavelength");
        primaryWaveLoc_ = locOf(line, line.tokens[1]);
    } else if (tag == "MNUM") {
        const int configs = integer(line, 1, "configuration count");
        if (configs > 1)
            note(Severity::Warning, locOf(line),
                 std::to_string(configs) +
                     " configurations: only the lens data stored in the surface blocks (the "
                     "current configuration) is imported; multi-configuration operands are "
                     "ignored");
        TagCount& c = skipped_["MNUM"];
        if (c.count++ == 0) c.first = locOf(line);
    } else {
        return false;
    }
    return true;
}

bool ZmxParser::surfaceCommand(const std::string& tag, const Line& line) {
    if (tag == "TYPE") {
        typeCommand(line);
    } else if (tag == "CURV") {
        // CURV <curvature> <solve type> <solve parameters...> "<pickup name>"
        Surface& s = current(line, tag);
        s.curvature = number(line, 1, "curvature");
        if (line.tokens.size() > 2) {
            const int solve = integer(line, 2, "solve type");
            if (solve != 0 && solve != 1) countSolve("CURV", locOf(line, line.tokens[2]));
        }
    } else if (tag == "DISZ") {
        Surface& s = current(line, tag);
        const std::string v = upper(arg(line, 1, "thickness").text);
        if (v == "INFINITY" || v == "INF")
            s.thicknessMm = kInfinity;
        else if (v == "-INFINITY" || v == "-INF")
            s.thicknessMm = -kInfinity;
        else
            s.thicknessMm = number(line, 1, "thickness");
    } else if (tag == "CONI") {
        current(line, tag).conic = number(line, 1, "conic constant");
    } else if (tag == "PARM") {
        parmCommand(line);
    } else if (tag == "XDAT") {
        xdatCommand(line);
    } else if (tag == "GLAS") {
        glassCommand(line);
    } else if (tag == "DIAM") {
        // DIAM <clear semi-diameter> <solve type> ...: the value is what Zemax computed (solve
        // type 0, automatic) or what the user fixed; either way it is the clear
        // semi-diameter, but only a fixed one vignettes sequential rays (as in Zemax).
        Surface& s = current(line, tag);
        s.clearSemiDiameterMm = number(line, 1, "semi-diameter");
        s.semiDiameterAutomatic =
            line.tokens.size() <= 2 || integer(line, 2, "semi-diameter solve type") == 0;
    } else if (tag == "MEMA") {
        current(line, tag).mechSemiDiameterMm = number(line, 1, "mechanical semi-diameter");
    } else if (tag == "STOP") {
        current(line, tag).stop = true;
    } else if (tag == "COAT") {
        Surface& s = current(line, tag);
        if (line.tokens.size() > 1) s.coating = std::string(line.tokens[1].text);
    } else if (tag == "COMM") {
        current(line, tag).comment = restOfLine(line, 1);
    } else {
        return apertureCommand(tag, line);
    }
    return true;
}

void ZmxParser::typeCommand(const Line& line) {
    Surface& s = current(line, "TYPE");
    const std::string type = upper(arg(line, 1, "surface type").text);
    surfaceTypes_.back() = type;
    if (type == "COORDBRK") s.coordinateBreak = CoordinateBreak{};
    if (type == "TOROIDAL") s.anamorphic = Anamorphic{Anamorphic::Kind::Toroidal};
    if (type == "BICONICX") s.anamorphic = Anamorphic{Anamorphic::Kind::Biconic};
    if (type != "STANDARD" && type != "EVENASPH" && type != "ODDASPH" && type != "COORDBRK" &&
        type != "TOROIDAL" && type != "BICONICX")
        unsupported_ = UnsupportedSurface{restOfLine(line, 1), locOf(line, line.tokens[1]), {}};
}

// PARM <n> <value>: its meaning depends on the surface type (EVENASPH: n = 1..8 multiplies
// r^2, r^4, ... r^16).
void ZmxParser::parmCommand(const Line& line) {
    const std::string tag = "PARM";
    Surface& s = current(line, tag);
    const int n = integer(line, 1, "parameter number");
    const double v = number(line, 2, "parameter value");
    const std::string& type = surfaceTypes_.back();
    if (unsupported_) {
        if (v != 0.0)
            unsupported_->lostParameters.push_back("PARM " + std::to_string(n) + " = " +
                                                   std::string(line.tokens[2].text));
    } else if (type == "EVENASPH" && n >= 1 && n <= static_cast<int>(s.asphere.size())) {
        s.asphere[n - 1] = v;
    } else if (type == "COORDBRK" && n >= 1 && n <= 6) {
        // COORDBRK: decenter x, y (lens units), tilt about x, y, z (degrees), order flag.
        CoordinateBreak& b = *s.coordinateBreak;
        double* const slot[] = {&b.decenterXMm, &b.decenterYMm, &b.tiltXDeg, &b.tiltYDeg,
                                &b.tiltZDeg};
        if (n <= 5)
            *slot[n - 1] = v;
        else
            b.tiltFirst = v != 0.0;
    } else if ((type == "TOROIDAL" || type == "BICONICX") && n == 1) {
        // The radius of rotation (TOROIDAL) or the x radius (BICONICX), lens units; 0 is
        // an infinite radius.
        s.anamorphic->xCurvature = v == 0.0 ? 0.0 : 1.0 / v;
    } else if (type == "BICONICX" && n == 2) {
        s.anamorphic->xConic = v;
    } else if (type == "TOROIDAL" && n >= 2 && n <= 8) {
        // alpha 1..7 multiply y^2 .. y^14 of the y-z profile.
        s.asphere[static_cast<size_t>(n - 2)] = v;
    } else if (type == "TOROIDAL" && n == 13) {
        if (v != 0.0)
            note(Severity::Error, locOf(line, line.tokens[2]),
                 "TOROIDAL PARM 13 = " + std::string(line.tokens[2].text) +
                     " Zernike sag terms: veil models the toroid without them (its XDAT "
                     "values would be lost)");
    } else if (type == "ODDASPH" && n >= 1 && n <= 8) {
        // ODDASPH: PARM n multiplies r^n. Even powers join the even asphere (r^2 n / 2 - 1),
        // odd ones the odd terms; r^1 would put a cone's tip on the axis.
        if (n == 1) {
            if (v != 0.0)
                note(Severity::Error, locOf(line, line.tokens[2]),
                     "ODDASPH PARM 1 = " + std::string(line.tokens[2].text) +
                         ": a term in r^1 (a cone at the vertex) is not supported by veil");
        } else if (n % 2 == 0) {
            s.asphere[static_cast<size_t>(n / 2 - 1)] = v;
        } else {
            s.oddAsphere[static_cast<size_t>((n - 3) / 2)] = v;
        }
    } else if (v != 0.0) {
        note(Severity::Warning, locOf(line, line.tokens[1]),
             "PARM " + std::to_string(n) + " = " + std::string(line.tokens[2].text) +
                 " has no meaning for a " + type + " surface and was ignored");
    }
}

void ZmxParser::xdatCommand(const Line& line) {
    const std::string tag = "XDAT";
    current(line, tag);
    if (unsupported_) {
        if (line.tokens.size() > 2 && number(line, 2, "extra data value") != 0.0)
            unsupported_->lostParameters.push_back("XDAT " + std::string(line.tokens[1].text) +
                                                   " = " + std::string(line.tokens[2].text));
    } else if (surfaceTypes_.back() == "TOROIDAL") {
        // The toroid's extra data: XDAT 1 is the number of Zernike terms, XDAT 2 their
        // normalization radius, XDAT 3 on the Zernike sag terms themselves; only a term that
        // is not zero changes the shape.
        const int n = integer(line, 1, "extra data number");
        if (n >= 3 && line.tokens.size() > 2 && number(line, 2, "extra data value") != 0.0)
            note(Severity::Error, locOf(line),
                 "TOROIDAL Zernike sag term XDAT " + std::string(line.tokens[1].text) + " = " +
                     std::string(line.tokens[2].text) + " is not modelled by veil");
    } else {
        note(Severity::Warning, locOf(line),
             "extra data (XDAT) on a " + surfaceTypes_.back() + " surface ignored");
    }
}

void ZmxParser::glassCommand(const Line& line) {
    const std::string tag = "GLAS";
    // GLAS <name> <solve> <pickup surface> <nd> <vd> <dPgF> <flags...>
    current(line, tag);
    GlassRef g;
    g.surface = static_cast<int>(rx_.surfaces.size()) - 1;
    g.name = std::string(arg(line, 1, "glass name").text);
    g.solve = line.tokens.size() > 2 ? integer(line, 2, "glass solve type") : 0;
    g.nd = optionalNumber(line, 4);
    g.vd = optionalNumber(line, 5);
    g.dPgF = optionalNumber(line, 6);
    g.loc = locOf(line, line.tokens[1]);
    if (g.solve == 2) countSolve("GLAS", locOf(line, line.tokens[2]));
    glasses_.push_back(std::move(g));
}

// Surface apertures: CLAP and OBSC rings (decided in importHoles()), their decenter OBDC;
// the other shapes are reported, not imported. False for a tag that is none of them.
bool ZmxParser::apertureCommand(const std::string& tag, const Line& line) {
    if ((tag == "CLAP" || tag == "OBSC") && line.tokens.size() >= 3 && isNumber(line, 1) &&
        isNumber(line, 2)) {
        // CLAP <min radius> <max radius> ...: rays pass between the radii. OBSC <min radius>
        // <max radius> ...: rays between the radii are blocked. Decided in importHoles().
        current(line, tag);
        SurfaceApertureRef a;
        a.surface = static_cast<int>(rx_.surfaces.size()) - 1;
        a.tag = tag;
        a.minRadius = number(line, 1, "minimum radius");
        a.maxRadius = number(line, 2, "maximum radius");
        a.text = trim(line.text);
        a.loc = locOf(line);
        surfaceApertures_.push_back(std::move(a));
    } else if (tag == "OBDC" && line.tokens.size() >= 3 && isNumber(line, 1) && isNumber(line, 2) &&
               !surfaceApertures_.empty() &&
               surfaceApertures_.back().surface == static_cast<int>(rx_.surfaces.size()) - 1) {
        // OBDC <x> <y>: the decenter of the surface's aperture.
        current(line, tag);
        surfaceApertures_.back().decenterX = number(line, 1, "aperture decenter x");
        surfaceApertures_.back().decenterY = number(line, 2, "aperture decenter y");
        surfaceApertures_.back().text += "; " + trim(line.text);
    } else if (tag == "CLAP" || tag == "OBSC" || tag == "SQAP" || tag == "OBSQ" || tag == "ELAP" ||
               tag == "OBEL" || tag == "UDAP" || tag == "OBDC") {
        current(line, tag);
        note(Severity::Warning, locOf(line),
             "surface aperture " + tag + " not imported: " + trim(line.text) +
                 " (only the clear semi-diameter DIAM limits rays)");
    } else {
        return false;
    }
    return true;
}

void ZmxParser::endSurface() {
    if (!unsupported_) return;
    std::string msg = "surface type " + unsupported_->type +
                      " is not supported by veil (read as a STANDARD surface it would lose its "
                      "shape";
    if (!unsupported_->lostParameters.empty())
        msg += ": " + joinNames(unsupported_->lostParameters);
    msg += ")";
    if (upper(unsupported_->type).rfind("QED_TYPE", 0) == 0)
        msg += "; veil models Forbes Q-type aspheres (a TOML surface's qbfs or qcon, "
               "docs/format.md) but does not read their .zmx encoding: write the surface in "
               "TOML from the file's normalisation radius and terms";
    note(Severity::Error, unsupported_->loc, msg);
    unsupported_.reset();
}

// Post-processing

void ZmxParser::resolveGlasses() {
    const std::vector<std::string>& preferred = rx_.system.glassCatalogs;
    const std::string where = preferred.empty()
                                  ? "in any loaded catalog"
                                  : "in " + joinNames(preferred) + " or any other loaded catalog";
    bool allFound = true;
    for (const GlassRef& g : glasses_) {
        Surface& s = rx_.surfaces[g.surface];
        const std::string name = upper(g.name);
        if (name == "MIRROR") {
            s.mirror = true;
            continue;
        }
        if (name == "___BLANK") {
            // Model glass: nd, Vd, dPgF stored on the line.
            const double nd = g.nd.value_or(0.0), vd = g.vd.value_or(0.0);
            if (nd == 1.0 && vd == 0.0) {
                s.material = Material::air();
                note(Severity::Info, g.loc, "model glass nd = 1, Vd = 0 imported as air");
            } else if (nd >= 1.0 && vd == 0.0) {
                // Vd = 0 is Zemax's constant (dispersion-free) index.
                s.material = Material::model(nd, 0.0);
            } else if (nd < 1.0 && nd >= 1.0 - kGasIndexBelowAir && vd == 0.0) {
                // An index a little below air's: a gas or vacuum relative to air (vacuum is
                // 0.99973), which veil's indices relative to air cannot hold below 1.
                s.material = Material::air();
                note(Severity::Warning, g.loc,
                     "model glass nd = " + formatNumber(nd) +
                         ", Vd = 0 (a gas or vacuum relative to air) imported as air: its "
                         "index differs by " +
                         formatNumber(1.0 - nd) + ", which veil leaves out");
            } else if (nd < 1.0 || vd < 0.0) {
                s.material = Material::model(std::max(nd, 1.0), 0.0);
                note(Severity::Error, g.loc,
                     "model glass nd = " + formatNumber(nd) + ", Vd = " + formatNumber(vd) +
                         " is not physical; imported as a constant index " +
                         formatNumber(s.material.nd));
            } else {
                s.material = Material::model(nd, vd, g.dPgF.value_or(0.0));
            }
            continue;
        }
        const Glass* glass = catalog_.find(g.name, preferred);
        const bool successor = !glass && (glass = catalog_.findSuccessor(g.name, preferred));
        if (successor)
            note(Severity::Info, g.loc,
                 "glass " + g.name + " is in no loaded catalog under that name; taken as " +
                     glass->name() + " (" + glass->catalog() + "), the glass the name denotes",
                 ImportNote::Topic::Glass);
        if (glass) {
            s.material = Material::catalog(glass->name());
            if (!successor && !preferred.empty() &&
                std::none_of(preferred.begin(), preferred.end(),
                             [&](const std::string& c) { return c == upper(glass->catalog()); }))
                note(Severity::Info, g.loc,
                     "glass " + g.name + " is not in " + joinNames(preferred) + "; taken from " +
                         glass->catalog());
            if (g.nd && *g.nd > 1.0 && !placeholderGlassData(g)) {
                const double n = glass->index(kLineD);
                if (std::isfinite(n) && std::abs(n - *g.nd) > 1e-4)
                    note(Severity::Info, g.loc,
                         "glass " + g.name + ": catalog nd = " + formatNumber(n) +
                             " differs from the nd = " + formatNumber(*g.nd) +
                             " stored in the file (different catalog version?)");
            }
            continue;
        }
        allFound = false;
        std::string msg = "unknown glass '" + g.name + "': not found " + where;
        const auto suggestions = catalog_.suggestions(g.name);
        if (!suggestions.empty()) msg += " (did you mean " + joinNames(suggestions) + "?)";
        if (placeholderGlassData(g)) {
            // nd 1.5, Vd 40: what a program writes for a glass it did not have (every unknown
            // glass of the corpus that stored it: COC, POLYSTYR, SSKN5, LAFN21, SILICA, ...),
            // not the glass's data. A lens of it would be wrong by percents (US 5,831,776's
            // silica at 248 nm: unfocused), so the name is kept, as an error.
            s.material = Material::catalog(g.name);
            note(Severity::Error, g.loc,
                 msg +
                     "; the file stores nd = 1.5, Vd = 40, the placeholder lens design programs "
                     "write for a glass they did not have, not this glass's data; supply the "
                     "glass in a catalog: " +
                     kGlassCatalogHint,
                 ImportNote::Topic::Glass);
        } else if (g.nd && g.vd && *g.nd > 1.0 && *g.vd > 0.0) {
            s.material = Material::model(*g.nd, *g.vd, g.dPgF.value_or(0.0));
            note(Severity::Warning, g.loc,
                 msg + "; replaced by the model glass nd = " + formatNumber(*g.nd) +
                     ", Vd = " + formatNumber(*g.vd) + " stored in the file",
                 ImportNote::Topic::Glass);
        } else {
            s.material = Material::catalog(g.name);
            note(Severity::Error, g.loc,
                 msg +
                     "; the file stores no usable nd/Vd, so the name is kept and the glass "
                     "must be supplied in a catalog before tracing: " +
                     kGlassCatalogHint,
                 ImportNote::Topic::Glass);
        }
    }
    // A catalog the file names but veil does not have matters only if a glass was then not
    // found; otherwise it is an Info of the import report.
    for (const auto& [name, loc] : unloadedCatalogs_)
        note(allFound ? Severity::Info : Severity::Warning, loc,
             "glass catalog " + name + " named by GCAT is not loaded; " +
                 (allFound ? std::string("every glass of the file was found in the loaded catalogs")
                           : "glasses are looked up in the other catalogs (" +
                                 std::string(kGlassCatalogHint) + ")"),
             allFound ? ImportNote::Topic::General : ImportNote::Topic::Glass);
}

void ZmxParser::applyMirrors() {
    // A mirror or a coordinate break keeps the medium the light came from (in order, so
    // mirror after mirror works). A break has no aperture of its own.
    for (size_t i = 1; i < rx_.surfaces.size(); ++i) {
        Surface& s = rx_.surfaces[i];
        if (s.mirror || s.coordinateBreak) s.material = rx_.surfaces[i - 1].material;
        if (s.coordinateBreak) {
            s.clearSemiDiameterMm = s.mechSemiDiameterMm = 0.0;
            s.semiDiameterAutomatic = false;
        }
    }
}

void ZmxParser::importHoles() {
    // A centred circular hole in the clear aperture becomes Surface::innerSemiDiameterMm: an
    // obscuration from the axis (OBSC 0 R) or the inner edge of an annular aperture (CLAP R
    // max). Everything else keeps the warning that DIAM alone limits rays.
    const int last = static_cast<int>(rx_.surfaces.size()) - 1;
    for (const SurfaceApertureRef& a : surfaceApertures_) {
        Surface& s = rx_.surfaces[a.surface];
        auto notImported = [&](const std::string& why) {
            note(Severity::Warning, a.loc,
                 "surface aperture " + a.tag + " not imported: " + a.text + " (" + why +
                     "; only the clear semi-diameter DIAM limits rays)");
        };
        if (a.decenterX != 0.0 || a.decenterY != 0.0) {
            notImported("decentered: only a centred circular hole is imported");
            continue;
        }
        const bool obscuration = a.tag == "OBSC";
        if (obscuration && a.minRadius > 0.0) {
            notImported("an annular obscuration: only one from the axis is imported as a hole");
            continue;
        }
        const double hole = obscuration ? a.maxRadius : a.minRadius;
        if (!(hole > 0.0)) {
            notImported(obscuration ? "an empty obscuration" : "no central hole");
            continue;
        }
        if (a.surface == 0 || a.surface == last) {
            notImported("the object and image surfaces take no hole");
            continue;
        }
        const bool inGlass = !s.material.isAir() || !rx_.surfaces[a.surface - 1].material.isAir();
        if (inGlass) {
            notImported("a hole in a surface of a lens element is not modelled");
            continue;
        }
        if (!(hole < s.clearSemiDiameterMm)) {
            notImported("the hole radius " + formatNumber(hole) +
                        " is not inside the clear semi-diameter DIAM " +
                        formatNumber(s.clearSemiDiameterMm));
            continue;
        }
        s.innerSemiDiameterMm = std::max(s.innerSemiDiameterMm, hole);
        std::string message = a.tag + " imported as a central hole of radius " +
                              formatNumber(hole) + " (hole_sd): " + a.text;
        if (!obscuration && a.maxRadius != s.clearSemiDiameterMm) {
            // The outer edge stays the DIAM: a smaller CLAP radius would vignette more.
            message += "; its outer radius " + formatNumber(a.maxRadius) +
                       " is not imported (the clear semi-diameter DIAM " +
                       formatNumber(s.clearSemiDiameterMm) + " limits rays)";
            note(a.maxRadius < s.clearSemiDiameterMm ? Severity::Warning : Severity::Info, a.loc,
                 message);
        } else {
            note(Severity::Info, a.loc, message);
        }
    }
}

void ZmxParser::convertUnits() {
    if (mmPerUnit_ == 1.0) return;
    const double f = mmPerUnit_;
    for (Surface& s : rx_.surfaces) {
        s.curvature /= f;
        s.thicknessMm *= f;  // infinity stays infinity
        s.clearSemiDiameterMm *= f;
        s.mechSemiDiameterMm *= f;
        s.innerSemiDiameterMm *= f;
        // asphere[i] multiplies r^(2i+2) and has units length^-(2i+1).
        for (size_t i = 0; i < s.asphere.size(); ++i)
            s.asphere[i] *= std::pow(f, -(2.0 * static_cast<double>(i) + 1.0));
        // oddAsphere[j] multiplies r^(2j+3): units length^-(2j+2).
        for (size_t j = 0; j < s.oddAsphere.size(); ++j)
            s.oddAsphere[j] *= std::pow(f, -(2.0 * static_cast<double>(j) + 2.0));
        if (s.anamorphic) s.anamorphic->xCurvature /= f;
        if (s.coordinateBreak) {
            s.coordinateBreak->decenterXMm *= f;
            s.coordinateBreak->decenterYMm *= f;
        }
    }
    note(Severity::Info, unitLoc_,
         "lens units " + unitName_ + ": lengths converted to mm (x " + formatNumber(f) + ")");
}

void ZmxParser::buildFields() {
    SystemData& sys = rx_.system;
    const int type = fieldType_.value_or(0);
    size_t n = std::max(xFields_.size(), yFields_.size());
    if (fieldCount_ && !oldFieldForm_) n = std::min<size_t>(n, std::max(*fieldCount_, 0));
    if (fieldCount_ && *fieldCount_ > static_cast<int>(n))
        note(Severity::Warning, fieldTypeLoc_,
             "FTYP announces " + std::to_string(*fieldCount_) + " fields but only " +
                 std::to_string(n) + " are given");
    for (size_t i = 0; i < n; ++i) {
        Field f;
        f.x = i < xFields_.size() ? xFields_[i] : 0.0;
        f.y = i < yFields_.size() ? yFields_[i] : 0.0;
        f.weight = i < fieldWeights_.size() ? fieldWeights_[i] : 1.0;
        double* factors[4] = {&f.vdx, &f.vdy, &f.vcx, &f.vcy};
        for (int k = 0; k < 4; ++k)
            if (i < vignetting_[k].size()) *factors[k] = vignetting_[k][i];
        sys.fields.push_back(f);
    }
    if (type == 0) {
        sys.fieldKind = SystemData::FieldKind::AngleDeg;
    } else if (type == 1) {
        sys.fieldKind = SystemData::FieldKind::ObjectHeightMm;
        for (Field& f : sys.fields) f.x *= mmPerUnit_, f.y *= mmPerUnit_;
    } else if (type == 2 || type == 3) {
        // Image heights: resolved into angles or object heights once the model exists
        // (tracer/sequential/image_fields.h).
        sys.fieldKind = type == 2 ? SystemData::FieldKind::ParaxialImageHeightMm
                                  : SystemData::FieldKind::RealImageHeightMm;
        for (Field& f : sys.fields) f.x *= mmPerUnit_, f.y *= mmPerUnit_;
    } else {
        static const char* kNames[] = {"angle", "object height", "paraxial image height",
                                       "real image height", "theodolite angle"};
        const std::string name =
            type >= 0 && type <= 4 ? kNames[type] : "type " + std::to_string(type);
        // The axial field (0, 0) means the same in every field type; other fields cannot be
        // converted without tracing.
        const size_t before = sys.fields.size();
        std::erase_if(sys.fields, [](const Field& f) { return f.x != 0.0 || f.y != 0.0; });
        note(Severity::Error, fieldTypeLoc_,
             "field type " + name +
                 " is not supported: " + std::to_string(before - sys.fields.size()) +
                 " off-axis field(s) dropped, only the axial field is kept");
    }
    if (sys.fields.empty()) {
        sys.fields.push_back({});
        note(Severity::Warning, fieldTypeLoc_.line ? fieldTypeLoc_ : FileLoc{file_, 1, 1},
             "no fields in the file; the axial field was added");
    }
}

void ZmxParser::buildWavelengths() {
    SystemData& sys = rx_.system;
    if (!wavm_.empty()) {
        // WAVM lists 24 slots; FTYP says how many are in use.
        const int n = waveCount_.value_or(static_cast<int>(wavm_.size()));
        for (int i = 1; i <= n; ++i) {
            const auto it = wavm_.find(i);
            if (it == wavm_.end()) {
                note(Severity::Warning, waveLoc_,
                     "wavelength " + std::to_string(i) + " announced by FTYP has no WAVM line");
                continue;
            }
            sys.wavelengths.push_back({it->second.first * 1000.0, it->second.second});
        }
    } else {
        size_t n = waveList_.size();
        if (waveCount_) n = std::min<size_t>(n, std::max(*waveCount_, 0));
        for (size_t i = 0; i < n; ++i)
            sys.wavelengths.push_back(
                {waveList_[i] * 1000.0, i < waveWeights_.size() ? waveWeights_[i] : 1.0});
    }
    if (sys.wavelengths.empty()) {
        sys.wavelengths.push_back({550.0, 1.0});
        note(Severity::Warning, FileLoc{file_, 1, 1},
             "no wavelengths in the file; 550 nm (the Zemax default) was used");
    }
    for (const Wavelength& w : sys.wavelengths)
        if (!(w.nm > 0.0))
            throw ParseError(waveLoc_, "wavelength " + formatNumber(w.nm) + " nm is not positive");
    sys.primaryWavelength = 0;
    if (primaryWave_) {
        const int p = *primaryWave_;
        if (p >= 1 && p <= static_cast<int>(sys.wavelengths.size()))
            sys.primaryWavelength = p - 1;
        else
            note(Severity::Warning, primaryWaveLoc_,
                 "primary wavelength " + std::to_string(p) + " is out of range 1.." +
                     std::to_string(sys.wavelengths.size()) + "; the first one is used");
    }
}

void ZmxParser::buildAperture() {
    SystemAperture& ap = rx_.system.aperture;
    if (apertureLines_.empty()) {
        note(Severity::Warning, FileLoc{file_, 1, 1},
             "no system aperture (ENPD, FNUM, OBNA, FLOA) in the file; float by stop size is "
             "used");
        ap = {SystemAperture::Kind::FloatByStop, 0.0};
        return;
    }
    if (apertureLines_.size() > 1)
        note(Severity::Warning, apertureLines_.back().loc,
             "several system aperture lines; the last one (" + apertureLines_.back().tag +
                 ") is used");
    const ApertureLine& a = apertureLines_.back();
    const bool objectAtInfinity =
        !rx_.surfaces.empty() && std::isinf(rx_.surfaces.front().thicknessMm);
    if (a.tag == "ENPD") {
        ap = {SystemAperture::Kind::EntrancePupilDiameter, a.value * mmPerUnit_};
    } else if (a.tag == "FNUM") {
        ap = {SystemAperture::Kind::ImageSpaceFNumber, a.value};
        if (a.flag != 0) {
            // Flag 1: paraxial working F/#, 1 / (2 n' u'). For an object at infinity it
            // equals the image space F/# (EFL / EPD) in air.
            if (objectAtInfinity)
                note(Severity::Info, a.loc,
                     "paraxial working F/# imported as image space F/# (equal for an object at "
                     "infinity)");
            else
                note(Severity::Warning, a.loc,
                     "paraxial working F/# with a finite object is not supported; the value was "
                     "imported as image space F/# (EFL / EPD)");
        }
    } else if (a.tag == "OBNA") {
        if (a.flag == 0) {
            ap = {SystemAperture::Kind::ObjectSpaceNA, a.value};
        } else {
            // Flag 1: object cone angle in degrees; NA = n sin(angle).
            constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
            ap = {SystemAperture::Kind::ObjectSpaceNA, std::sin(a.value * kDegToRad)};
            const bool air = rx_.surfaces.empty() || rx_.surfaces.front().material.isAir();
            note(air ? Severity::Info : Severity::Warning, a.loc,
                 "object cone angle " + formatNumber(a.value) +
                     " deg converted to NA = " + formatNumber(ap.value) +
                     (air ? "" : " assuming n = 1 in object space (the object medium is glass)"));
        }
    } else {
        ap = {SystemAperture::Kind::FloatByStop, 0.0};
    }
}

void ZmxParser::checkApertures() {
    for (size_t i = 0; i < rx_.surfaces.size(); ++i) {
        Surface& s = rx_.surfaces[i];
        if (s.mechSemiDiameterMm > 0.0 && s.clearSemiDiameterMm > s.mechSemiDiameterMm) {
            note(Severity::Warning, s.origin,
                 "clear semi-diameter " + formatNumber(s.clearSemiDiameterMm) +
                     " mm exceeds the mechanical semi-diameter " +
                     formatNumber(s.mechSemiDiameterMm) +
                     " mm; the mechanical semi-diameter was raised to match");
            s.mechSemiDiameterMm = s.clearSemiDiameterMm;
        }
    }
}

void ZmxParser::summarize() {
    for (const auto& [tag, c] : skipped_) {
        const SkippedTag* s = findSkipped(tag);
        note(Severity::Info, c.first,
             std::to_string(c.count) + " " + tag +
                 " line(s) skipped: " + (s ? s->meaning : "not needed"));
    }
    for (const auto& [tag, u] : unknown_) {
        const auto& [c, text] = u;
        note(Severity::Warning, c.first,
             "unknown command '" + tag + "' ignored" +
                 (c.count > 1 ? " (" + std::to_string(c.count) + " lines; the first: " : ": ") +
                 text + (c.count > 1 ? ")" : ""),
             ImportNote::Topic::UnknownCommand,
             tag + " (line " + std::to_string(c.first.line) +
                 (c.count > 1 ? ", " + std::to_string(c.count) + " lines)" : ")"));
    }
    for (const auto& [tag, c] : solves_)
        note(Severity::Info, c.first,
             tag + ": " + std::to_string(c.count) +
                 " surface(s) carry a solve or pickup; the current values were imported, the "
                 "solve itself is not kept");
}

Prescription ZmxParser::parse(std::string_view decoded) {
    rx_.sourceFile = file_;
    const std::vector<Line> lines = splitLines(decoded);
    const bool hasSurf = std::any_of(lines.begin(), lines.end(),
                                     [](const Line& l) { return l.tokens[0].text == "SURF"; });
    if (!hasSurf) throw ParseError({file_, 1, 1}, "not a Zemax lens file: no SURF line found");
    for (const Line& line : lines) dispatch(line);
    endSurface();

    resolveGlasses();
    applyMirrors();
    importHoles();
    convertUnits();
    buildFields();
    buildWavelengths();
    buildAperture();
    checkApertures();
    summarize();

    std::stable_sort(report_.begin(), report_.end(), [](const ImportNote& a, const ImportNote& b) {
        return a.loc.line < b.loc.line;
    });
    rx_.report = std::move(report_);
    rx_.assignNames();
    rx_.validate();
    rx_.notePlausibility();
    return std::move(rx_);
}

}  // namespace

// Public Functions

Prescription readZmxText(std::string_view bytes, const std::string& fileName,
                         const GlassCatalog& catalog) {
    const std::string decoded = decodeText(bytes, fileName);
    return ZmxParser(fileName, catalog).parse(decoded);
}

Prescription readZmx(const std::filesystem::path& path, const GlassCatalog& catalog) {
    const std::optional<std::string> bytes = readInputFile(path);
    if (!bytes) throw ParseError({path.string()}, "cannot open the file");
    return readZmxText(*bytes, path.string(), catalog);
}

}  // namespace veil
