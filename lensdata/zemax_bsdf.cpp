#include "lensdata/zemax_bsdf.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "lensdata/errors.h"
#include "lensdata/input_file.h"

namespace veil {

namespace {

struct Token {
    std::string text;
    int line = 0, column = 0;
};

bool sameWord(const std::string& a, const char* b) {
    const std::string_view bv(b);
    if (a.size() != bv.size()) return false;
    for (size_t i = 0; i < a.size(); ++i)
        if (std::tolower(static_cast<unsigned char>(a[i])) !=
            std::tolower(static_cast<unsigned char>(bv[i])))
            return false;
    return true;
}

// Whitespace-separated tokens with their positions; lines whose first non-blank character is
// '#' are comments (kept apart while no token has been read yet).
class Tokens {
  public:
    Tokens(const std::string& text, std::string file, std::vector<std::string>& comments)
        : file_(std::move(file)) {
        int line = 1;
        size_t i = 0;
        while (i <= text.size()) {
            const size_t end = std::min(text.find('\n', i), text.size());
            std::string_view l(text.data() + i, end - i);
            const size_t first = l.find_first_not_of(" \t\r");
            if (first != std::string_view::npos && l[first] == '#') {
                if (tokens_.empty()) {
                    std::string c(l.substr(first + 1));
                    while (!c.empty() && (c.back() == '\r' || c.back() == ' ')) c.pop_back();
                    comments.push_back(c);
                }
            } else {
                size_t k = 0;
                while (k < l.size()) {
                    while (k < l.size() && std::isspace(static_cast<unsigned char>(l[k]))) ++k;
                    const size_t s = k;
                    while (k < l.size() && !std::isspace(static_cast<unsigned char>(l[k]))) ++k;
                    if (k > s)
                        tokens_.push_back(
                            {std::string(l.substr(s, k - s)), line, static_cast<int>(s) + 1});
                }
            }
            if (end >= text.size()) break;
            i = end + 1;
            ++line;
        }
        endLine_ = line;
    }

    bool done() const { return pos_ >= tokens_.size(); }
    const Token& peek() const { return tokens_[pos_]; }
    FileLoc here() const {
        if (done()) return {file_, endLine_, 1};
        return {file_, peek().line, peek().column};
    }
    FileLoc locOf(const Token& t) const { return {file_, t.line, t.column}; }
    [[noreturn]] void fail(const std::string& message) const { throw ParseError(here(), message); }

    Token next(const std::string& what) {
        if (done()) fail("the file ends where " + what + " should be");
        return tokens_[pos_++];
    }
    Token keyword(const char* word) {
        const Token t = next(std::string("the keyword ") + word);
        if (!sameWord(t.text, word)) {
            --pos_;
            fail(std::string("expected the keyword ") + word + " here (got '" + t.text + "')");
        }
        return t;
    }
    double number(const std::string& what) {
        const Token t = next(what);
        char* end = nullptr;
        const double v = std::strtod(t.text.c_str(), &end);
        if (end != t.text.c_str() + t.text.size() || !std::isfinite(v)) {
            --pos_;
            fail("expected " + what + " (a finite number), got '" + t.text + "'");
        }
        return v;
    }
    int count(const char* keyword) {
        const Token t = next(std::string("the count after ") + keyword);
        char* end = nullptr;
        const long v = std::strtol(t.text.c_str(), &end, 10);
        if (end != t.text.c_str() + t.text.size() || v < 1 || v > 100000) {
            --pos_;
            fail(std::string("expected the number of ") + keyword +
                 " values (a whole number from 1 to 100000), got '" + t.text + "'");
        }
        return static_cast<int>(v);
    }
    void back() { --pos_; }

  private:
    std::vector<Token> tokens_;
    size_t pos_ = 0;
    std::string file_;
    int endLine_ = 1;
};

// A keyword, its count and that many angles in [lo, hi], strictly ascending.
std::vector<double> angleList(Tokens& t, const char* keyword, double lo, double hi) {
    t.keyword(keyword);
    const int n = t.count(keyword);
    std::vector<double> v;
    for (int i = 0; i < n; ++i) {
        const FileLoc at = t.here();
        const double a = t.number(std::string(keyword) + " value " + std::to_string(i + 1) +
                                  " of " + std::to_string(n));
        if (a < lo || a > hi)
            throw ParseError(at, std::string(keyword) + " " + messageNumber(a) + " is outside [" +
                                     messageNumber(lo) + ", " + messageNumber(hi) + "] degrees");
        if (!v.empty() && !(a > v.back()))
            throw ParseError(at, std::string(keyword) + " values must ascend (" + messageNumber(a) +
                                     " follows " + messageNumber(v.back()) + ")");
        v.push_back(a);
    }
    return v;
}

}  // namespace

std::ostream& operator<<(std::ostream& os, const ZemaxBsdf& d) {
    return os << "ZemaxBsdf{" << (d.transmission ? "BTDF" : "BRDF") << ", "
              << (d.planeSymmetric ? "PlaneSymmetrical" : "Asymmetrical") << ", " << d.blocks.size()
              << " incidences x " << d.azimuthDeg.size() << " azimuths x " << d.radialDeg.size()
              << " radial angles}";
}

ZemaxBsdf parseZemaxBsdf(const std::string& text, const std::string& fileName) {
    ZemaxBsdf d;
    d.source = fileName;
    Tokens t(text, fileName, d.comments);

    t.keyword("Source");
    t.next("the source (Measured)");
    t.keyword("Symmetry");
    const Token sym = t.next("the symmetry");
    if (sameWord(sym.text, "PlaneSymmetrical")) {
        d.planeSymmetric = true;
    } else if (sameWord(sym.text, "Asymmetrical")) {
        d.planeSymmetric = false;
    } else if (sameWord(sym.text, "Asymmetrical4D")) {
        throw ParseError(t.locOf(sym),
                         "Asymmetrical4D data (an anisotropic sample measured at several "
                         "rotations) are not read: the scene gives parts no orientation in "
                         "their plane; use PlaneSymmetrical or Asymmetrical data");
    } else {
        throw ParseError(t.locOf(sym), "unknown Symmetry '" + sym.text +
                                           "' (expected PlaneSymmetrical or Asymmetrical)");
    }
    t.keyword("SpectralContent");
    const Token spectral = t.next("the spectral content");
    if (!sameWord(spectral.text, "Monochrome"))
        throw ParseError(t.locOf(spectral),
                         "SpectralContent '" + spectral.text +
                             "' is not read: give one Monochrome file per wavelength band");
    t.keyword("ScatterType");
    const Token type = t.next("the scatter type");
    if (sameWord(type.text, "BRDF")) {
        d.transmission = false;
    } else if (sameWord(type.text, "BTDF")) {
        d.transmission = true;
    } else {
        throw ParseError(t.locOf(type),
                         "unknown ScatterType '" + type.text + "' (expected BRDF or BTDF)");
    }
    t.keyword("SampleRotation");
    const FileLoc rotAt = t.here();
    const int rotations = t.count("SampleRotation");
    if (rotations != 1)
        throw ParseError(rotAt, "SampleRotation " + std::to_string(rotations) +
                                    ": only data of one sample rotation are read");
    t.number("the sample rotation angle");

    const FileLoc aoiAt = t.here();
    std::vector<double> aoi = angleList(t, "AngleOfIncidence", 0.0, 90.0);
    (void)aoiAt;
    const FileLoc azAt = t.here();
    d.azimuthDeg = angleList(t, "ScatterAzimuth", 0.0, 360.0);
    const double azEnd = d.planeSymmetric ? 180.0 : 360.0;
    if (d.azimuthDeg.front() != 0.0 || d.azimuthDeg.back() != azEnd || d.azimuthDeg.size() < 2)
        throw ParseError(azAt, std::string("ScatterAzimuth must run from 0 to ") +
                                   messageNumber(azEnd) + " degrees for " +
                                   (d.planeSymmetric ? "PlaneSymmetrical" : "Asymmetrical") +
                                   " data (got " + messageNumber(d.azimuthDeg.front()) + " to " +
                                   messageNumber(d.azimuthDeg.back()) + ")");
    const FileLoc radAt = t.here();
    d.radialDeg = angleList(t, "ScatterRadial", 0.0, 180.0);
    if (d.radialDeg.front() != 0.0 || d.radialDeg.size() < 2)
        throw ParseError(radAt,
                         "ScatterRadial must start at 0 (the specular direction) and "
                         "list at least two angles");

    if (!t.done() && sameWord(t.peek().text, "Monochrome")) t.next("Monochrome");
    t.keyword("DataBegin");
    const size_t nAz = d.azimuthDeg.size(), nRad = d.radialDeg.size();
    for (double incidence : aoi) {
        ZemaxBsdfBlock b;
        b.incidenceDeg = incidence;
        b.loc = t.here();
        if (!t.done() && sameWord(t.peek().text, "DataEnd"))
            t.fail("DataEnd after " + std::to_string(d.blocks.size()) +
                   " blocks: " + "AngleOfIncidence lists " + std::to_string(aoi.size()));
        t.keyword("TIS");
        const FileLoc tisAt = t.here();
        b.fileTis = t.number("the block's TIS");
        if (b.fileTis < 0.0 || b.fileTis > 1.0)
            throw ParseError(tisAt,
                             "TIS " + messageNumber(b.fileTis) + " is not a fraction in [0, 1]");
        b.values.reserve(nAz * nRad);
        for (size_t a = 0; a < nAz; ++a) {
            const FileLoc rowAt = t.here();
            int rowLine = 0;
            for (size_t r = 0; r < nRad; ++r) {
                const FileLoc at = t.here();
                if (!t.done() && r > 0 && t.peek().line != rowLine)
                    throw ParseError(rowAt, "the row of azimuth " + messageNumber(d.azimuthDeg[a]) +
                                                " (incidence " + messageNumber(incidence) +
                                                ") has " + std::to_string(r) +
                                                " values; ScatterRadial lists " +
                                                std::to_string(nRad));
                const double v = t.number("a BSDF value");
                if (r == 0) rowLine = at.line;
                if (v < 0.0) throw ParseError(at, "negative BSDF value " + messageNumber(v));
                b.values.push_back(v);
            }
            if (!t.done() && t.peek().line == rowLine)
                throw ParseError(t.here(), "the row of azimuth " + messageNumber(d.azimuthDeg[a]) +
                                               " (incidence " + messageNumber(incidence) +
                                               ") has more values than the " +
                                               std::to_string(nRad) + " ScatterRadial lists");
        }
        d.blocks.push_back(std::move(b));
    }
    if (t.done()) t.fail("the file ends without DataEnd");
    if (sameWord(t.peek().text, "TIS"))
        t.fail("more blocks than the " + std::to_string(aoi.size()) + " AngleOfIncidence lists");
    t.keyword("DataEnd");
    if (!t.done()) t.fail("unexpected text after DataEnd: '" + t.peek().text + "'");
    return d;
}

ZemaxBsdf readZemaxBsdf(const std::filesystem::path& path) {
    const std::optional<std::string> text = readInputFile(path);
    if (!text) throw ParseError({path.string(), 0, 0}, "cannot open the BSDF file");
    return parseZemaxBsdf(*text, path.string());
}

void writeZemaxBsdf(std::ostream& os, const ZemaxBsdf& d) {
    for (const std::string& c : d.comments) os << "#" << c << "\n";
    auto list = [&](const char* keyword, const std::vector<double>& v) {
        os << keyword << "\t" << v.size() << "\n";
        for (size_t i = 0; i < v.size(); ++i) os << (i ? "\t" : "") << messageNumber(v[i]);
        os << "\n";
    };
    os << "Source\tMeasured\n";
    os << "Symmetry\t" << (d.planeSymmetric ? "PlaneSymmetrical" : "Asymmetrical") << "\n";
    os << "SpectralContent\tMonochrome\n";
    os << "ScatterType\t" << (d.transmission ? "BTDF" : "BRDF") << "\n";
    os << "SampleRotation\t1\n0\n";
    std::vector<double> aoi;
    for (const ZemaxBsdfBlock& b : d.blocks) aoi.push_back(b.incidenceDeg);
    list("AngleOfIncidence", aoi);
    list("ScatterAzimuth", d.azimuthDeg);
    list("ScatterRadial", d.radialDeg);
    os << "\nMonochrome\nDataBegin\n";
    std::ostringstream v;
    v.precision(6);
    for (const ZemaxBsdfBlock& b : d.blocks) {
        os << "TIS\t" << messageNumber(b.fileTis) << "\n";
        for (size_t a = 0; a < d.azimuthDeg.size(); ++a) {
            for (size_t r = 0; r < d.radialDeg.size(); ++r) {
                v.str("");
                v << std::scientific << b.values[a * d.radialDeg.size() + r];
                os << (r ? "\t" : "") << v.str();
            }
            os << "\n";
        }
    }
    os << "DataEnd\n";
}

}  // namespace veil
