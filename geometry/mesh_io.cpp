#include "geometry/mesh_io.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "lensdata/output_file.h"
#include "lensdata/toml_document.h"

namespace veil {

namespace {

// OpenMesh Importer

// Receives what an OpenMesh reader parses, as a plain vertex list and face list. Every
// other attribute (normals, colours, texture coordinates, status) is ignored; halfedge
// calls are never made by the STL, OBJ, PLY and OFF readers.
//
// A corrupt count in a header (PLY, OFF) makes OpenMesh's readers loop for billions of
// elements on a failed stream. No file can hold more vertices or faces than it has bytes, so
// the importer stops the read with an ImportAbort once a count exceeds the file size.
struct ImportAbort {
    std::string message;
};

class RawImporter final : public OpenMesh::IO::BaseImporter {
  public:
    explicit RawImporter(uintmax_t fileBytes) : fileBytes_(fileBytes) {}

    std::vector<Vec3> vertices;
    std::vector<uint32_t> faceStart{0};  // faces as ranges of faceCorners
    std::vector<uint32_t> faceCorners;
    size_t facesOffered = 0;
    std::string firstError;  // a face the reader handed over that we cannot take

    size_t faceCount() const { return faceStart.size() - 1; }

    OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
        return add_vertex(OpenMesh::Vec3d(p[0], p[1], p[2]));
    }
    OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
        if (vertices.size() >= fileBytes_) tooMany(vertices.size() + 1, "vertices");
        vertices.emplace_back(p[0], p[1], p[2]);
        return OpenMesh::VertexHandle(static_cast<int>(vertices.size() - 1));
    }
    OpenMesh::VertexHandle add_vertex() override { return add_vertex(OpenMesh::Vec3d(0, 0, 0)); }
    void set_point(OpenMesh::VertexHandle vh, const OpenMesh::Vec3f& p) override {
        if (vh.is_valid() && static_cast<size_t>(vh.idx()) < vertices.size())
            vertices[vh.idx()] = Vec3(p[0], p[1], p[2]);
    }

    OpenMesh::FaceHandle add_face(const VHandles& corners) override {
        if (++facesOffered > fileBytes_) tooMany(facesOffered, "faces");
        for (const OpenMesh::VertexHandle& vh : corners) {
            if (!vh.is_valid() || static_cast<size_t>(vh.idx()) >= vertices.size()) {
                if (firstError.empty()) {
                    firstError = "face " + std::to_string(facesOffered) + " refers to vertex " +
                                 std::to_string(vh.idx() + 1) +
                                 " (counting from 1), but the file has " +
                                 std::to_string(vertices.size()) + " vertices";
                }
                return OpenMesh::FaceHandle();
            }
        }
        if (corners.size() < 3) {
            if (firstError.empty())
                firstError = "face " + std::to_string(facesOffered) + " has fewer than 3 corners";
            return OpenMesh::FaceHandle();
        }
        for (const OpenMesh::VertexHandle& vh : corners)
            faceCorners.push_back(static_cast<uint32_t>(vh.idx()));
        faceStart.push_back(static_cast<uint32_t>(faceCorners.size()));
        return OpenMesh::FaceHandle(static_cast<int>(faceCount() - 1));
    }

    // Everything below is data we do not use.
    OpenMesh::HalfedgeHandle add_edge(OpenMesh::VertexHandle, OpenMesh::VertexHandle) override {
        return OpenMesh::HalfedgeHandle();
    }
    OpenMesh::FaceHandle add_face(OpenMesh::HalfedgeHandle) override {
        return OpenMesh::FaceHandle();
    }
    void add_face_texcoords(OpenMesh::FaceHandle, OpenMesh::VertexHandle,
                            const std::vector<OpenMesh::Vec2f>&) override {}
    void add_face_texcoords(OpenMesh::FaceHandle, OpenMesh::VertexHandle,
                            const std::vector<OpenMesh::Vec3f>&) override {}
    void set_face_texindex(OpenMesh::FaceHandle, int) override {}
    void set_halfedge(OpenMesh::VertexHandle, OpenMesh::HalfedgeHandle) override {}
    void set_normal(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
    void set_normal(OpenMesh::VertexHandle, const OpenMesh::Vec3d&) override {}
    void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec3uc&) override {}
    void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec4uc&) override {}
    void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
    void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec4f&) override {}
    void set_texcoord(OpenMesh::VertexHandle, const OpenMesh::Vec2f&) override {}
    void set_status(OpenMesh::VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void set_next(OpenMesh::HalfedgeHandle, OpenMesh::HalfedgeHandle) override {}
    void set_face(OpenMesh::HalfedgeHandle, OpenMesh::FaceHandle) override {}
    void request_face_texcoords2D() override {}
    void set_texcoord(OpenMesh::HalfedgeHandle, const OpenMesh::Vec2f&) override {}
    void set_texcoord(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
    void set_texcoord(OpenMesh::HalfedgeHandle, const OpenMesh::Vec3f&) override {}
    void set_status(OpenMesh::HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec3uc&) override {}
    void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec4uc&) override {}
    void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec3f&) override {}
    void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec4f&) override {}
    void set_status(OpenMesh::EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void set_normal(OpenMesh::FaceHandle, const OpenMesh::Vec3f&) override {}
    void set_normal(OpenMesh::FaceHandle, const OpenMesh::Vec3d&) override {}
    void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec3uc&) override {}
    void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec4uc&) override {}
    void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec3f&) override {}
    void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec4f&) override {}
    void set_status(OpenMesh::FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
    void add_texture_information(int, std::string) override {}

    void reserve(unsigned int nV, unsigned int /*nE*/, unsigned int nF) override {
        if (nV > fileBytes_) tooMany(nV, "vertices");
        if (nF > fileBytes_) tooMany(nF, "faces");
        vertices.reserve(nV);
        faceStart.reserve(nF + 1);
    }
    size_t n_vertices() const override { return vertices.size(); }
    size_t n_faces() const override { return faceCount(); }
    size_t n_edges() const override { return 0; }

  private:
    [[noreturn]] void tooMany(uintmax_t count, const char* what) const {
        throw ImportAbort{"the file announces or holds at least " + std::to_string(count) + " " +
                          what + ", more than its " + std::to_string(fileBytes_) +
                          " bytes can hold (corrupt header?)"};
    }

    uintmax_t fileBytes_;
};

// OpenMesh writes its complaints to the global streams omerr/omlog/omout (connected to
// std::cerr, std::clog, std::cout). Library code must not print, and the complaints are
// the best reason we can give in a ParseError, so while a file is read the three standard
// streams write into strings instead (their buffers swapped, then restored). Not by
// disconnecting OpenMesh's multiplexers from them: disconnect() forgets its target without
// deleting it, 16 bytes leaked per read. The streams are process-wide: one read at a time.
std::mutex& openMeshStreamsMutex() {
    static std::mutex m;
    return m;
}

class OpenMeshMessages {
  public:
    OpenMeshMessages()
        : lock_(openMeshStreamsMutex()),
          errEnabled_(omerr().is_enabled()),
          logEnabled_(omlog().is_enabled()),
          outEnabled_(omout().is_enabled()) {
        omerr().flush();
        omlog().flush();
        omout().flush();
        cerrBuf_ = std::cerr.rdbuf(errors_.rdbuf());
        clogBuf_ = std::clog.rdbuf(other_.rdbuf());
        coutBuf_ = std::cout.rdbuf(other_.rdbuf());
    }
    ~OpenMeshMessages() {
        omerr().flush();
        omlog().flush();
        omout().flush();
        std::cerr.rdbuf(cerrBuf_);
        std::clog.rdbuf(clogBuf_);
        std::cout.rdbuf(coutBuf_);
        // A reader left by an exception may have disabled a stream.
        errEnabled_ ? omerr().enable() : omerr().disable();
        logEnabled_ ? omlog().enable() : omlog().disable();
        outEnabled_ ? omout().enable() : omout().disable();
    }
    OpenMeshMessages(const OpenMeshMessages&) = delete;
    OpenMeshMessages& operator=(const OpenMeshMessages&) = delete;

    // The error messages so far, on one line.
    std::string errors() {
        omerr().flush();
        std::string s = errors_.str();
        std::replace(s.begin(), s.end(), '\n', ' ');
        while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
        return s;
    }

  private:
    std::lock_guard<std::mutex> lock_;
    std::ostringstream errors_;
    std::ostringstream other_;
    bool errEnabled_, logEnabled_, outEnabled_;
    std::streambuf* cerrBuf_ = nullptr;
    std::streambuf* clogBuf_ = nullptr;
    std::streambuf* coutBuf_ = nullptr;
};

// File Formats

enum class MeshFormat { Stl, Obj, Ply, Off };

std::string lowerExtension(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

std::optional<MeshFormat> formatOf(const std::filesystem::path& path) {
    const std::string ext = lowerExtension(path);
    if (ext == ".stl") return MeshFormat::Stl;
    if (ext == ".obj") return MeshFormat::Obj;
    if (ext == ".ply") return MeshFormat::Ply;
    if (ext == ".off") return MeshFormat::Off;
    return std::nullopt;
}

// Checking Files Before OpenMesh
//
// OpenMesh's readers are lenient: a number they cannot parse becomes 0 or the previous value,
// a truncated file yields zero-filled vertices, a comment line in an OFF file shifts every
// later number, an ASCII STL solid whose name contains "outer" grows a garbage facet, and a
// PLY header with a count that is not a number makes the header parser allocate without end.
// None of that says a word. So each file is checked here first, line by line, against what
// OpenMesh's reader expects (ParseErrors at file:line:col), and the counts the file states or
// shows are compared with what OpenMesh delivers afterwards.

constexpr size_t kUnknown = std::numeric_limits<size_t>::max();

struct Prescan {
    std::string format;
    size_t vertices = kUnknown;  // vertices OpenMesh must deliver
    size_t faces = kUnknown;     // faces it must hand over (STL: facets in the file)
};

struct Word {
    std::string_view text;
    int column;  // from 1
};

std::vector<Word> splitWords(std::string_view line) {
    std::vector<Word> words;
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        const size_t start = i;
        while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        if (i > start)
            words.push_back({line.substr(start, i - start), static_cast<int>(start) + 1});
    }
    return words;
}

bool isFiniteNumber(std::string_view w) {
    if (!w.empty() && w[0] == '+') w.remove_prefix(1);
    double v = 0.0;
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    return ec == std::errc() && end == w.data() + w.size() && std::isfinite(v);
}

std::optional<long long> parseInteger(std::string_view w) {
    if (!w.empty() && w[0] == '+') w.remove_prefix(1);
    long long v = 0;
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    if (ec != std::errc() || end != w.data() + w.size()) return std::nullopt;
    return v;
}

std::string lower(std::string_view w) {
    std::string s(w);
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

class LineReader {
  public:
    explicit LineReader(const std::filesystem::path& path)
        : path_(path), in_(path, std::ios::binary) {}
    bool next() {
        if (!std::getline(in_, text_)) return false;
        if (!text_.empty() && text_.back() == '\r') text_.pop_back();
        ++line_;
        words_ = splitWords(text_);
        return true;
    }
    const std::string& text() const { return text_; }
    const std::vector<Word>& words() const { return words_; }
    int line() const { return line_; }
    [[noreturn]] void fail(int column, const std::string& message) const {
        throw ParseError(FileLoc{path_.string(), line_, column}, message);
    }
    // Every word from `first` on is a finite number, at least `count` of them.
    void requireNumbers(size_t first, size_t count, const char* what) const {
        if (words_.size() < first + count)
            fail(0, std::string(what) + " needs " + std::to_string(count) + " numbers, found " +
                        std::to_string(words_.size() > first ? words_.size() - first : 0));
        for (size_t i = first; i < words_.size(); ++i)
            if (!isFiniteNumber(words_[i].text))
                fail(words_[i].column, std::string(what) + ": expected a finite number, got '" +
                                           std::string(words_[i].text) + "'");
    }

  private:
    const std::filesystem::path& path_;
    std::ifstream in_;
    std::string text_;
    std::vector<Word> words_;
    int line_ = 0;
};

// Binary or ASCII is decided as OpenMesh decides: binary when the size is 84 + 50 x (the
// triangle count in the header). In ASCII, OpenMesh starts a facet at any line holding
// "outer" and reads the next three lines as its corners, whatever they say.
Prescan prescanStl(const std::filesystem::path& path) {
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(path, ec);
    std::ifstream in(path, std::ios::binary);
    std::string head(512, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<size_t>(in.gcount()));
    if (head.size() >= 84) {
        const auto byte = [&](int i) {
            return static_cast<uint32_t>(static_cast<uint8_t>(head[i]));
        };
        const uint32_t count = byte(80) | byte(81) << 8 | byte(82) << 16 | byte(83) << 24;
        if (84 + 50 * static_cast<uint64_t>(count) == size)
            return {"STL (binary)", kUnknown, count};
        if (head.find('\0') != std::string::npos) {
            throw ParseError(FileLoc{path.string(), 0, 0},
                             "binary STL of " + std::to_string(size) +
                                 " bytes, but its header announces " + std::to_string(count) +
                                 " triangles, which take 84 + 50 x " + std::to_string(count) +
                                 " = " + std::to_string(84 + 50 * static_cast<uint64_t>(count)) +
                                 " bytes (truncated or corrupt file?)");
        }
    } else if (head.find('\0') != std::string::npos) {
        throw ParseError(FileLoc{path.string(), 0, 0},
                         "binary STL shorter than its 84-byte header");
    }

    Prescan p{"STL (ASCII)", kUnknown, 0};
    LineReader r(path);
    int cornersToRead = 0;  // vertex lines still due after "outer loop"
    int corners = 0;
    bool inLoop = false;
    while (r.next()) {
        const auto& w = r.words();
        if (w.empty()) {
            if (cornersToRead > 0)
                r.fail(0,
                       "expected a 'vertex' line (OpenMesh reads the 3 "
                       "lines after 'outer loop' as the corners)");
            continue;
        }
        const std::string kw = lower(w[0].text);
        const size_t outer = std::min(r.text().find("outer"), r.text().find("OUTER"));
        if (outer != std::string::npos && kw != "outer")
            r.fail(static_cast<int>(outer) + 1,
                   "OpenMesh's STL reader takes every line containing 'outer' for the start of a "
                   "facet; rename what holds it");
        if (cornersToRead > 0 && kw != "vertex")
            r.fail(w[0].column,
                   "expected a 'vertex' line (OpenMesh reads the 3 lines after "
                   "'outer loop' as the corners), got '" +
                       std::string(w[0].text) + "'");
        if (kw == "outer") {
            if (inLoop) r.fail(w[0].column, "'outer loop' before the 'endloop' of the last one");
            inLoop = true;
            cornersToRead = 3;
            corners = 0;
            ++p.faces;
        } else if (kw == "vertex") {
            if (!inLoop) r.fail(w[0].column, "'vertex' outside 'outer loop' ... 'endloop'");
            if (w.size() != 4) r.fail(0, "a vertex line needs 3 numbers: vertex x y z");
            r.requireNumbers(1, 3, "vertex");
            --cornersToRead;
            ++corners;
        } else if (kw == "endloop") {
            if (corners != 3)
                r.fail(w[0].column,
                       "a facet needs 3 vertices, this one has " + std::to_string(corners));
            inLoop = false;
        }
    }
    if (inLoop) r.fail(0, "the file ends inside a facet");
    return p;
}

Prescan prescanObj(const std::filesystem::path& path) {
    Prescan p{"OBJ", 0, 0};
    LineReader r(path);
    while (r.next()) {
        const auto& w = r.words();
        if (w.empty()) continue;
        if (w[0].text == "v") {
            r.requireNumbers(1, 3, "vertex");
            ++p.vertices;
        } else if (w[0].text == "f") {
            if (w.size() < 4) r.fail(0, "a face needs at least 3 corners");
            for (size_t i = 1; i < w.size(); ++i) {
                const std::string_view corner = w[i].text.substr(0, w[i].text.find('/'));
                const std::optional<long long> index = parseInteger(corner);
                if (!index || *index == 0)
                    r.fail(w[i].column,
                           "expected a vertex number (from 1, or negative from the "
                           "end), got '" +
                               std::string(w[i].text) + "'");
            }
            ++p.faces;
        }
    }
    return p;
}

// Plain "OFF" only; the variants with colours, normals or texture coordinates (COFF, NOFF,
// STOFF, ...) are left to OpenMesh unchecked.
Prescan prescanOff(const std::filesystem::path& path) {
    Prescan p{"OFF", kUnknown, kUnknown};
    LineReader r(path);
    std::vector<Word> counts;
    auto skipBlankAndComments = [&]() {
        while (r.next()) {
            if (r.words().empty()) continue;
            if (r.words()[0].text[0] == '#')
                r.fail(r.words()[0].column,
                       "OpenMesh's OFF reader does not skip comment "
                       "lines; remove them");
            return true;
        }
        return false;
    };
    if (!skipBlankAndComments()) r.fail(0, "empty file");
    // Only plain OFF is checked here and read: OpenMesh takes any first word ending in OFF
    // (COFF, NOFF, 4OFF, "OFF10", ...) and then believes whatever counts follow (a face of
    // 777777777755 corners asked for 2 GB; found by fuzzing).
    if (r.words()[0].text != "OFF")
        r.fail(r.words()[0].column, "expected the header 'OFF' (veil reads plain OFF files: "
                                    "vertices as x y z, faces as n i1 .. in), got '" +
                                        std::string(r.words()[0].text) + "'");
    if (r.words().size() > 1) {
        counts.assign(r.words().begin() + 1, r.words().end());
    } else {
        if (!skipBlankAndComments()) r.fail(0, "the file ends before the vertex and face counts");
        counts = r.words();
    }
    std::optional<long long> nv, nf;
    if (counts.size() >= 2) {
        nv = parseInteger(counts[0].text);
        nf = parseInteger(counts[1].text);
    }
    if (!nv || !nf || *nv < 0 || *nf < 0) r.fail(0, "expected the counts 'vertices faces edges'");
    p.vertices = static_cast<size_t>(*nv);
    p.faces = static_cast<size_t>(*nf);
    auto ended = [&](const char* what, size_t done, size_t total) {
        r.fail(0, "the file ends after " + std::to_string(done) + " of its " +
                      std::to_string(total) + " " + what + " (truncated?)");
    };
    for (size_t v = 0; v < p.vertices; ++v) {
        if (!skipBlankAndComments()) ended("vertices", v, p.vertices);
        r.requireNumbers(0, 3, "vertex");
    }
    for (size_t f = 0; f < p.faces; ++f) {
        if (!skipBlankAndComments()) ended("faces", f, p.faces);
        const auto& w = r.words();
        const std::optional<long long> n = parseInteger(w[0].text);
        if (!n || *n < 3)
            r.fail(w[0].column, "a face starts with its number of corners, at least 3; got '" +
                                    std::string(w[0].text) + "'");
        if (w.size() < static_cast<size_t>(*n) + 1)
            r.fail(0, "the face announces " + std::to_string(*n) + " corners but lists " +
                          std::to_string(w.size() - 1));
        for (size_t i = 1; i <= static_cast<size_t>(*n); ++i) {
            const std::optional<long long> index = parseInteger(w[i].text);
            if (!index || *index < 0 || *index >= *nv)
                r.fail(w[i].column, "expected a vertex index from 0 to " + std::to_string(*nv - 1) +
                                        ", got '" + std::string(w[i].text) + "'");
        }
    }
    return p;
}

// The header, then the body, before OpenMesh sees the file: OpenMesh's own parser loops without
// end, allocating, on a header line it cannot parse (an element count that is not a number),
// and believes any list count in the body (a face of -3 corners, read as 4294967293, grew the
// memory at 0.5 GB/s). Every count is checked against what the file holds before anything is
// allocated, and every face's corners against the vertex count.
struct PlyProperty {
    std::string name;
    bool list = false;
    std::string countType, type;  // countType: lists only
};
struct PlyElement {
    std::string name;
    size_t count = 0;
    std::vector<PlyProperty> properties;
};

size_t plyTypeSize(std::string_view t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "double" || t == "float64") return 8;
    return 4;  // int, uint, float and their sized names
}
bool plyFloatType(std::string_view t) {
    return t == "float" || t == "double" || t == "float32" || t == "float64";
}
bool plyUnsignedType(std::string_view t) {
    return t == "uchar" || t == "uint8" || t == "ushort" || t == "uint16" || t == "uint" ||
           t == "uint32";
}
// The corner list of a face element (OpenMesh reads the first list property as it).
bool plyCorners(const PlyElement& e, const PlyProperty& p) {
    return e.name == "face" && p.list && (p.name == "vertex_indices" || p.name == "vertex_index");
}

// An integer read from a binary body, as text (a value no integer type holds as such).
std::string integerText(double x) {
    if (std::abs(x) < 9e18 && x == std::floor(x)) return std::to_string(static_cast<long long>(x));
    std::ostringstream os;
    os << x;
    return os.str();
}

// A body's list count is at most this many entries: far beyond any polygon, and what fits.
constexpr long long kMaxPlyListCount = 1 << 20;

void checkPlyAscii(LineReader& r, const std::vector<PlyElement>& elements, size_t vertices) {
    for (const PlyElement& e : elements) {
        for (size_t k = 0; k < e.count; ++k) {
            if (!r.next())
                r.fail(0, "the file ends after " + std::to_string(k) + " of its " +
                              std::to_string(e.count) + " " + e.name + " elements (truncated?)");
            const auto& w = r.words();
            size_t at = 0;
            auto need = [&](const std::string& what) {
                if (at >= w.size())
                    r.fail(0,
                           e.name + " " + std::to_string(k) + ": the line ends before its " + what);
            };
            for (const PlyProperty& p : e.properties) {
                if (!p.list) {
                    need("'" + p.name + "'");
                    if (!isFiniteNumber(w[at].text))
                        r.fail(w[at].column, "'" + p.name + "': expected a finite number, got '" +
                                                 std::string(w[at].text) + "'");
                    ++at;
                    continue;
                }
                need("list '" + p.name + "'");
                const std::optional<long long> n = parseInteger(w[at].text);
                if (!n || *n < 0 || *n > kMaxPlyListCount)
                    r.fail(w[at].column, "list '" + p.name + "' starts with its count (0 to " +
                                             std::to_string(kMaxPlyListCount) + "), got '" +
                                             std::string(w[at].text) + "'");
                if (w.size() - at - 1 < static_cast<size_t>(*n))
                    r.fail(w[at].column, "list '" + p.name + "' announces " + std::to_string(*n) +
                                             " values, but the line holds " +
                                             std::to_string(w.size() - at - 1));
                ++at;
                for (long long i = 0; i < *n; ++i, ++at) {
                    if (plyCorners(e, p)) {
                        const std::optional<long long> index = parseInteger(w[at].text);
                        if (!index || *index < 0 || static_cast<size_t>(*index) >= vertices)
                            r.fail(w[at].column,
                                   "expected a vertex index from 0 to " +
                                       std::to_string(static_cast<long long>(vertices) - 1) +
                                       ", got '" + std::string(w[at].text) + "'");
                    } else if (!isFiniteNumber(w[at].text)) {
                        r.fail(w[at].column, "list '" + p.name +
                                                 "': expected a finite number, got '" +
                                                 std::string(w[at].text) + "'");
                    }
                }
            }
            if (at != w.size())
                r.fail(w[at].column, e.name + " " + std::to_string(k) + " has " +
                                         std::to_string(w.size() - at) +
                                         " values more than its properties");
        }
    }
}

void checkPlyBinary(const std::filesystem::path& path, uintmax_t bodyStart, bool bigEndian,
                    const std::vector<PlyElement>& elements, size_t vertices) {
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(path, ec);
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(bodyStart));
    uintmax_t at = bodyStart;
    auto fail = [&](const std::string& message) {
        throw ParseError(FileLoc{path.string(), 0, 0},
                         "byte " + std::to_string(at) + " of the PLY body: " + message);
    };
    auto ends = [&](const PlyElement& e, size_t k) {
        fail("the file ends inside " + e.name + " " + std::to_string(k) + " of " +
             std::to_string(e.count) + " (truncated?)");
    };
    // One value of type t, as a double (integers up to 2^32 exactly).
    auto value = [&](const std::string& t, const PlyElement& e, size_t k) {
        const size_t n = plyTypeSize(t);
        unsigned char b[8] = {};
        if (size - at < n || !in.read(reinterpret_cast<char*>(b), static_cast<std::streamsize>(n)))
            ends(e, k);
        if (bigEndian) std::reverse(b, b + n);
        at += n;
        uint64_t bits = 0;
        for (size_t i = 0; i < n; ++i) bits |= uint64_t{b[i]} << (8 * i);
        if (t == "float" || t == "float32") return double(std::bit_cast<float>(uint32_t(bits)));
        if (plyFloatType(t)) return std::bit_cast<double>(bits);
        if (plyUnsignedType(t)) return static_cast<double>(bits);
        const int shift = static_cast<int>(64 - 8 * n);  // sign-extend
        return static_cast<double>(static_cast<int64_t>(bits << shift) >> shift);
    };
    for (const PlyElement& e : elements) {
        const bool fixed = std::none_of(e.properties.begin(), e.properties.end(),
                                        [](const PlyProperty& p) { return p.list; });
        if (fixed && e.name != "vertex") {
            // Nothing to check inside: its size alone.
            uintmax_t record = 0;
            for (const PlyProperty& p : e.properties) record += plyTypeSize(p.type);
            if (record != 0 && (size - at) / record < e.count) ends(e, (size - at) / record);
            at += record * e.count;
            in.seekg(static_cast<std::streamoff>(at));
            continue;
        }
        for (size_t k = 0; k < e.count; ++k) {
            for (const PlyProperty& p : e.properties) {
                if (!p.list) {
                    const double x = value(p.type, e, k);
                    if (!std::isfinite(x))
                        fail(e.name + " " + std::to_string(k) + ": '" + p.name +
                             "' is not a finite number");
                    continue;
                }
                const double n = value(p.countType, e, k);
                if (!(n >= 0.0 && n <= static_cast<double>(kMaxPlyListCount)))
                    fail(e.name + " " + std::to_string(k) + ": list '" + p.name + "' announces " +
                         integerText(n) + " values (0 to " + std::to_string(kMaxPlyListCount) +
                         ")");
                const size_t count = static_cast<size_t>(n);
                if ((size - at) / plyTypeSize(p.type) < count) ends(e, k);
                for (size_t i = 0; i < count; ++i) {
                    const double x = value(p.type, e, k);
                    if (plyCorners(e, p) ? !(x >= 0.0 && x < static_cast<double>(vertices))
                                         : !std::isfinite(x))
                        fail(e.name + " " + std::to_string(k) + ": " +
                             (plyCorners(e, p)
                                  ? "vertex index " + integerText(x) + " outside 0 to " +
                                        std::to_string(static_cast<long long>(vertices) - 1)
                                  : "'" + p.name + "' is not a finite number"));
                }
            }
        }
    }
}

Prescan prescanPly(const std::filesystem::path& path) {
    Prescan p{"PLY", kUnknown, kUnknown};
    LineReader r(path);
    auto isType = [](std::string_view t) {
        static constexpr std::string_view kTypes[] = {
            "char", "uchar", "short", "ushort", "int",   "uint",   "float",   "double",
            "int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"};
        return std::find(std::begin(kTypes), std::end(kTypes), t) != std::end(kTypes);
    };
    bool format = false, ascii = false, bigEndian = false;
    std::vector<PlyElement> elements;
    uintmax_t headerBytes = 0;
    while (r.next()) {
        headerBytes += r.text().size() + 1;  // '\r' of a CRLF line: see below
        const auto& w = r.words();
        if (r.line() == 1) {
            if (r.text() != "ply") r.fail(1, "a PLY file starts with a line 'ply'");
            continue;
        }
        if (w.empty()) r.fail(0, "empty line in the PLY header");
        const std::string_view kw = w[0].text;
        if (kw == "comment" || kw == "obj_info") continue;
        if (kw == "end_header") {
            if (!format) r.fail(0, "the PLY header has no 'format' line");
            size_t vertices = 0;
            for (const PlyElement& e : elements)
                if (e.name == "vertex") vertices = e.count;
            if (ascii) {
                checkPlyAscii(r, elements, vertices);
            } else {
                // The body starts after the header's last newline, found in the bytes
                // themselves (a header with CRLF lines is one byte a line longer).
                std::ifstream in(path, std::ios::binary);
                std::string head(static_cast<size_t>(2 * headerBytes + 16), '\0');
                in.read(head.data(), static_cast<std::streamsize>(head.size()));
                head.resize(static_cast<size_t>(in.gcount()));
                const size_t end = head.find("end_header");
                const size_t newline = end == std::string::npos ? end : head.find('\n', end);
                if (newline == std::string::npos)
                    r.fail(0, "the PLY header's 'end_header' line has no newline");
                checkPlyBinary(path, newline + 1, bigEndian, elements, vertices);
            }
            return p;
        }
        if (kw == "format") {
            // OpenMesh reads a version that is not a number forever (found by fuzzing).
            if (format) r.fail(0, "a second 'format' line in the PLY header");
            if (w.size() != 3 ||
                (w[1].text != "ascii" && w[1].text != "binary_little_endian" &&
                 w[1].text != "binary_big_endian") ||
                w[2].text != "1.0")
                r.fail(0, "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
            p.format = w[1].text == "ascii" ? "PLY (ASCII)" : "PLY (binary)";
            ascii = w[1].text == "ascii";
            bigEndian = w[1].text == "binary_big_endian";
            format = true;
        } else if (kw == "element") {
            const std::optional<long long> n =
                w.size() == 3 && w[2].text.size() <= 10 ? parseInteger(w[2].text) : std::nullopt;
            if (!n || *n < 0)
                r.fail(0, "expected 'element <name> <count>', got '" + r.text() + "'");
            if (w[1].text == "vertex") p.vertices = static_cast<size_t>(*n);
            if (w[1].text == "face") p.faces = static_cast<size_t>(*n);
            elements.push_back({std::string(w[1].text), static_cast<size_t>(*n), {}});
        } else if (kw == "property") {
            if (elements.empty()) r.fail(0, "'property' before any 'element'");
            const bool list =
                w.size() == 5 && w[1].text == "list" && isType(w[2].text) && isType(w[3].text);
            if (!list && !(w.size() == 3 && isType(w[1].text)))
                r.fail(0,
                       "expected 'property <type> <name>' or 'property list <type> <type> "
                       "<name>', got '" +
                           r.text() + "'");
            if (list && plyFloatType(w[2].text))
                r.fail(w[2].column,
                       "a list's count is an integer type, got '" + std::string(w[2].text) + "'");
            PlyProperty prop;
            prop.list = list;
            prop.name = std::string(w[list ? 4 : 2].text);
            prop.type = std::string(w[list ? 3 : 1].text);
            if (list) prop.countType = std::string(w[2].text);
            elements.back().properties.push_back(std::move(prop));
        } else {
            r.fail(w[0].column, "unknown PLY header line '" + r.text() + "'");
        }
    }
    r.fail(0, "the PLY header has no 'end_header' line");
}

Prescan prescan(MeshFormat format, const std::filesystem::path& path) {
    switch (format) {
        case MeshFormat::Stl:
            return prescanStl(path);
        case MeshFormat::Obj:
            return prescanObj(path);
        case MeshFormat::Ply:
            return prescanPly(path);
        case MeshFormat::Off:
            return prescanOff(path);
    }
    return {};
}

// Mesh Analysis

struct PositionHash {
    size_t operator()(const Vec3& p) const {
        size_t h = 0;
        for (int a = 0; a < 3; ++a) {
            const uint64_t bits = std::bit_cast<uint64_t>(p[a] + 0.0);  // -0 as +0
            h ^= std::hash<uint64_t>{}(bits) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
        }
        return h;
    }
};

bool zeroArea(const TriangleMesh& m, const std::array<uint32_t, 3>& t) {
    const Vec3 n =
        glm::cross(m.vertices[t[1]] - m.vertices[t[0]], m.vertices[t[2]] - m.vertices[t[0]]);
    return n.x == 0.0 && n.y == 0.0 && n.z == 0.0;
}

// Divergence theorem about the centre of the bounds (keeps the terms small).
double signedVolumeOf(const TriangleMesh& m) {
    if (m.triangles.empty()) return 0.0;
    const Bounds3 b = m.bounds();
    const Vec3 c = 0.5 * (b.lo + b.hi);
    double sum = 0.0;
    for (const auto& t : m.triangles)
        sum +=
            glm::dot(m.vertices[t[0]] - c, glm::cross(m.vertices[t[1]] - c, m.vertices[t[2]] - c));
    return sum / 6.0;
}

struct UnionFind {
    std::vector<uint32_t> parent;
    explicit UnionFind(size_t n) {
        parent.reserve(n);
        for (size_t i = 0; i < n; ++i) parent.push_back(static_cast<uint32_t>(i));
    }
    uint32_t find(uint32_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    }
    void unite(uint32_t a, uint32_t b) { parent[find(a)] = find(b); }
};

// Edge and vertex topology of a triangle list whose triangles have three distinct corners.
void countTopology(const TriangleMesh& m, MeshReadReport& r) {
    struct EdgeUse {
        uint64_t key;  // lower index << 32 | higher index
        uint32_t triangle;
        bool forward;  // the triangle runs from the lower to the higher index
    };
    std::vector<EdgeUse> uses;
    uses.reserve(3 * m.triangles.size());
    for (uint32_t t = 0; t < m.triangles.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const uint32_t a = m.triangles[t][k], b = m.triangles[t][(k + 1) % 3];
            const uint64_t lo = std::min(a, b), hi = std::max(a, b);
            uses.push_back({lo << 32 | hi, t, a < b});
        }
    }
    std::sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) {
        return x.key < y.key || (x.key == y.key && x.triangle < y.triangle);
    });

    // Corner 3t+k is vertex k of triangle t. Around each vertex, the corners of triangles
    // sharing an edge at that vertex are joined; more than one group is a non-manifold vertex.
    UnionFind fans(3 * m.triangles.size());
    auto cornerOf = [&](uint32_t t, uint32_t v) {
        const auto& tri = m.triangles[t];
        return 3 * t + (tri[0] == v ? 0u : tri[1] == v ? 1u : 2u);
    };
    for (size_t i = 0; i < uses.size();) {
        size_t j = i;
        size_t forward = 0;
        while (j < uses.size() && uses[j].key == uses[i].key) forward += uses[j++].forward;
        const size_t count = j - i;
        if (count == 1) ++r.boundaryEdges;
        if (count > 2) ++r.nonManifoldEdges;
        if (count == 2 && forward != 1) ++r.inconsistentEdges;
        const auto lo = static_cast<uint32_t>(uses[i].key >> 32);
        const auto hi = static_cast<uint32_t>(uses[i].key & 0xffffffffu);
        for (size_t k = i + 1; k < j; ++k) {
            fans.unite(cornerOf(uses[k].triangle, lo), cornerOf(uses[i].triangle, lo));
            fans.unite(cornerOf(uses[k].triangle, hi), cornerOf(uses[i].triangle, hi));
        }
        i = j;
    }
    std::vector<int64_t> fanOf(m.vertices.size(), -1);
    std::vector<bool> counted(m.vertices.size(), false);
    for (uint32_t c = 0; c < 3 * m.triangles.size(); ++c) {
        const uint32_t v = m.triangles[c / 3][c % 3];
        const uint32_t root = fans.find(c);
        if (fanOf[v] < 0) {
            fanOf[v] = root;
        } else if (fanOf[v] != root && !counted[v]) {
            counted[v] = true;
            ++r.nonManifoldVertices;
        }
    }
}

// Splits a polygon (vertex indices, no two consecutive equal) into triangles by ear
// clipping in the plane that faces its Newell normal. For a convex polygon this is the fan
// from its first corner, as in OpenMesh's TriMesh; unlike a fan it also handles concave
// polygons and corners lying on a straight edge (T-vertices) without zero-area triangles.
// A remainder with no ear (a self-intersecting or collinear polygon) is split as a fan.
void triangulatePolygon(const std::vector<Vec3>& pos, std::vector<uint32_t> rest,
                        std::vector<std::array<uint32_t, 3>>& out) {
    Vec3 n(0.0);
    for (size_t i = 0; i < rest.size(); ++i) {
        const Vec3& a = pos[rest[i]];
        const Vec3& b = pos[rest[(i + 1) % rest.size()]];
        n += Vec3((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    const Vec3 an = glm::abs(n);
    const int axis = an.x >= an.y && an.x >= an.z ? 0 : an.y >= an.z ? 1 : 2;
    int u = (axis + 1) % 3, v = (axis + 2) % 3;  // (u, v, axis) right-handed
    if (n[axis] < 0.0) std::swap(u, v);          // so the polygon runs counter-clockwise
    auto at = [&](uint32_t i) { return Vec2(pos[i][u], pos[i][v]); };
    auto cross = [](const Vec2& a, const Vec2& b) { return a.x * b.y - a.y * b.x; };

    // Candidates are tried going round from corner 1 and the search goes on after each clip,
    // so a convex polygon clips (0, 1, 2), (0, 2, 3), ...: the fan from corner 0.
    size_t k = 1, misses = 0;
    while (rest.size() > 3 && n[axis] != 0.0) {
        const size_t m = rest.size();
        if (k >= m) k = 0;
        const uint32_t a = rest[(k + m - 1) % m], b = rest[k], c = rest[(k + 1) % m];
        const Vec2 A = at(a), B = at(b), C = at(c);
        bool ear = cross(B - A, C - A) > 0.0;  // not reflex, not straight
        for (size_t q = 0; ear && q < m; ++q) {
            const uint32_t x = rest[q];
            if (x == a || x == b || x == c) continue;
            const Vec2 X = at(x);
            ear = !(cross(B - A, X - A) >= 0.0 && cross(C - B, X - B) >= 0.0 &&
                    cross(A - C, X - C) >= 0.0);
        }
        if (ear) {
            out.push_back({a, b, c});
            rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(k));  // k: the next corner
            misses = 0;
        } else {
            k = (k + 1) % m;
            if (++misses >= m) break;  // no ear left
        }
    }
    for (size_t j = 1; j + 1 < rest.size(); ++j) out.push_back({rest[0], rest[j], rest[j + 1]});
}

// From the reader's faces to a clean indexed triangle mesh plus the report (steps 1 to 5 of
// the header).
TriangleMesh buildMesh(const RawImporter& raw, MeshReadReport& r) {
    // Merge equal positions; remember the first vertex at each.
    std::unordered_map<Vec3, uint32_t, PositionHash> firstAt;
    firstAt.reserve(raw.vertices.size());
    std::vector<uint32_t> merged(raw.vertices.size());
    std::vector<Vec3> positions;
    for (size_t i = 0; i < raw.vertices.size(); ++i) {
        const Vec3 p = raw.vertices[i] + Vec3(0.0);  // -0 as +0
        auto [it, inserted] = firstAt.try_emplace(p, static_cast<uint32_t>(positions.size()));
        if (inserted) positions.push_back(p);
        merged[i] = it->second;
    }

    // Triangles with a repeated corner are dropped; zero-area ones are kept for the
    // topology: a sliver along an edge closes a T-junction, and dropping it first would
    // report the mesh open although the surface has no gap.
    TriangleMesh all;
    all.vertices = std::move(positions);
    std::vector<uint32_t> polygon;
    for (size_t f = 0; f < raw.faceCount(); ++f) {
        polygon.clear();
        for (uint32_t k = raw.faceStart[f]; k < raw.faceStart[f + 1]; ++k) {
            const uint32_t v = merged[raw.faceCorners[k]];
            if (polygon.empty() || polygon.back() != v) polygon.push_back(v);
        }
        while (polygon.size() > 1 && polygon.front() == polygon.back()) polygon.pop_back();
        const bool isTriangle = raw.faceStart[f + 1] - raw.faceStart[f] == 3;
        if (polygon.size() < 3 || (isTriangle && polygon[0] == polygon[2])) {
            ++r.degenerateTrianglesDropped;
            continue;
        }
        if (!isTriangle) ++r.polygonsTriangulated;
        triangulatePolygon(all.vertices, polygon, all.triangles);
    }
    countTopology(all, r);

    // Keep triangles with area, and only the vertices they use, in first-use order.
    TriangleMesh mesh;
    std::vector<int64_t> newIndex(all.vertices.size(), -1);
    for (const auto& t : all.triangles) {
        if (zeroArea(all, t)) {
            ++r.degenerateTrianglesDropped;
            continue;
        }
        std::array<uint32_t, 3> u{};
        for (int k = 0; k < 3; ++k) {
            if (newIndex[t[k]] < 0) {
                newIndex[t[k]] = static_cast<int64_t>(mesh.vertices.size());
                mesh.vertices.push_back(all.vertices[t[k]]);
            }
            u[k] = static_cast<uint32_t>(newIndex[t[k]]);
        }
        mesh.triangles.push_back(u);
    }
    r.unusedVerticesDropped = all.vertices.size() - mesh.vertices.size();
    r.duplicateVerticesMerged += raw.vertices.size() - all.vertices.size();

    r.signedVolume = signedVolumeOf(mesh);
    if (r.isClosedSolid() && r.signedVolume < 0.0) {
        for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
        r.signedVolume = -r.signedVolume;
        r.orientationReversed = true;
    }
    r.vertices = mesh.vertices.size();
    r.triangles = mesh.triangles.size();
    return mesh;
}

// Rotation About One Axis

// Right-handed rotation by `deg` about axis 0 (x), 1 (y) or 2 (z). Multiples of 90 degrees
// are exact, so a rotated cube lands on exact coordinates.
glm::dmat3 axisRotation(int axis, double deg) {
    double c, s;
    const double quarterTurns = deg / 90.0;
    if (quarterTurns == std::round(quarterTurns)) {
        const int q = static_cast<int>(std::fmod(std::fmod(quarterTurns, 4.0) + 4.0, 4.0));
        static constexpr double kCos[4] = {1, 0, -1, 0}, kSin[4] = {0, 1, 0, -1};
        c = kCos[q];
        s = kSin[q];
    } else {
        const double rad = deg * std::numbers::pi / 180.0;
        c = std::cos(rad);
        s = std::sin(rad);
    }
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;  // the plane rotated: y-z, z-x, x-y
    glm::dmat3 m(1.0);                                 // m[column][row]
    m[i][i] = c;
    m[i][j] = s;
    m[j][i] = -s;
    m[j][j] = c;
    return m;
}

// Writing Files

// Runs `write` on a stream to path.tmp, then renames it over path.
template <class WriteFn>
void writeAtomically(const std::filesystem::path& path, std::ios::openmode mode, WriteFn write) {
    const std::filesystem::path tmp = temporaryFor(path);
    {
        errno = 0;
        std::ofstream out(tmp, mode | std::ios::out | std::ios::trunc);
        if (!out)
            throw std::runtime_error("cannot write " + path.string() + ": cannot create " +
                                     tmp.string() + ": " + systemReason());
        write(out);
        out.close();
        if (!out) {
            const std::string reason = systemReason();
            removeQuietly(tmp);
            throw std::runtime_error("cannot write " + path.string() + ": " + reason);
        }
    }
    commitFile(tmp, path);
}

void checkObjectIds(const TriangleMesh& mesh, std::span<const int> objectOfTriangle,
                    const char* who) {
    if (!objectOfTriangle.empty() && objectOfTriangle.size() != mesh.triangles.size())
        throw std::invalid_argument(std::string(who) + ": " +
                                    std::to_string(objectOfTriangle.size()) + " object ids for " +
                                    std::to_string(mesh.triangles.size()) + " triangles");
}

std::string objGroupName(int id, std::span<const std::string> names) {
    std::string name = (id >= 0 && static_cast<size_t>(id) < names.size() && !names[id].empty())
                           ? names[id]
                           : "object" + std::to_string(id);
    for (char& c : name)
        if (std::isspace(static_cast<unsigned char>(c))) c = '_';
    return name;
}

template <class T>
void putLittleEndian(std::ostream& out, T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
    out.write(reinterpret_cast<const char*>(bytes), sizeof(T));
}

// Scene File Reading

Vec3 readVec3(const TomlValue& v) {
    if (!v.isArray()) v.failExpected("an array of 3 numbers [x, y, z]");
    const std::vector<TomlValue> items = v.asArray();
    if (items.size() != 3)
        v.fail(v.path() + " must have 3 numbers [x, y, z], not " + std::to_string(items.size()));
    return {items[0].asNumber(), items[1].asNumber(), items[2].asNumber()};
}

}  // namespace

// MeshReadReport Public Methods

std::string MeshReadReport::problems() const {
    std::vector<std::string> parts;
    if (boundaryEdges > 0)
        parts.push_back("open: " + std::to_string(boundaryEdges) + " boundary edges");
    if (nonManifoldEdges > 0)
        parts.push_back(std::to_string(nonManifoldEdges) +
                        " non-manifold edges (shared by 3 or more triangles)");
    if (inconsistentEdges > 0)
        parts.push_back("inconsistent orientation: " + std::to_string(inconsistentEdges) +
                        " edges shared by triangles running the same way");
    std::string s;
    for (const std::string& p : parts) s += (s.empty() ? "" : "; ") + p;
    return s;
}

std::ostream& operator<<(std::ostream& os, const MeshReadReport& r) {
    os << "MeshReadReport{" << r.file << ", " << r.format << ": " << r.vertices << " vertices, "
       << r.triangles << " triangles from " << r.facesRead << " faces";
    if (r.isClosedSolid()) {
        os << ", closed solid, volume " << r.signedVolume;
    } else {
        os << ", " << r.problems();
    }
    if (r.nonManifoldVertices > 0) os << ", " << r.nonManifoldVertices << " non-manifold vertices";
    if (r.polygonsTriangulated > 0) os << ", " << r.polygonsTriangulated << " polygons split";
    if (r.duplicateVerticesMerged > 0)
        os << ", " << r.duplicateVerticesMerged << " duplicate vertices merged";
    if (r.degenerateTrianglesDropped > 0)
        os << ", " << r.degenerateTrianglesDropped << " degenerate triangles dropped";
    if (r.unusedVerticesDropped > 0)
        os << ", " << r.unusedVerticesDropped << " unused vertices dropped";
    if (r.orientationReversed) os << ", was inside out (reversed)";
    return os << "}";
}

// Mesh Reading

TriangleMesh readMeshFile(const std::filesystem::path& path, MeshReadReport* report) {
    const FileLoc where{path.string(), 0, 0};
    const std::optional<MeshFormat> format = formatOf(path);
    if (!format)
        throw ParseError(where, "unknown mesh format '" + path.extension().string() +
                                    "' (expected .stl, .obj, .ply or .off)");
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        throw ParseError(
            where, std::filesystem::exists(path, ec) ? "not a regular file" : "no such mesh file");
    {
        std::ifstream probe(path, std::ios::binary);
        if (!probe) throw ParseError(where, "cannot open mesh file");
    }

    MeshReadReport r;
    r.file = path.string();
    const Prescan pre = prescan(*format, path);
    r.format = pre.format;

    RawImporter raw(std::filesystem::file_size(path, ec));
    {
        OpenMeshMessages messages;
        OpenMesh::IO::Options options;  // positions and faces only
        bool ok = false;
        try {
            ok = OpenMesh::IO::IOManager().read(path.string(), raw, options);
        } catch (const ImportAbort& abort) {
            throw ParseError(where, "cannot read this " + r.format + " file: " + abort.message);
        }
        const std::string complaint = messages.errors();
        if (!ok) {
            throw ParseError(where, "OpenMesh cannot read this " + r.format + " file" +
                                        (complaint.empty() ? "" : ": " + complaint));
        }
    }
    if (!raw.firstError.empty()) throw ParseError(where, raw.firstError);
    if (pre.vertices != kUnknown && raw.vertices.size() != pre.vertices)
        throw ParseError(where, "OpenMesh read " + std::to_string(raw.vertices.size()) +
                                    " vertices, but the file has " + std::to_string(pre.vertices));
    // STL: OpenMesh drops degenerate facets before handing them over.
    if (pre.faces != kUnknown && *format != MeshFormat::Stl && raw.facesOffered != pre.faces)
        throw ParseError(where, "OpenMesh read " + std::to_string(raw.facesOffered) +
                                    " faces, but the file has " + std::to_string(pre.faces));
    for (size_t i = 0; i < raw.vertices.size(); ++i) {
        const Vec3& p = raw.vertices[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            std::ostringstream os;
            os << "vertex " << i + 1 << " has a coordinate that is not a finite number " << p;
            throw ParseError(where, os.str());
        }
    }

    r.facesRead = raw.faceCount();
    if (*format == MeshFormat::Stl) {
        // OpenMesh merged equal corners and dropped facets with repeated corners itself.
        r.facesRead = std::max(pre.faces, raw.faceCount());
        r.degenerateTrianglesDropped = r.facesRead - raw.faceCount();
        const size_t corners = 3 * r.facesRead;
        r.duplicateVerticesMerged =
            corners > raw.vertices.size() ? corners - raw.vertices.size() : 0;
    }
    TriangleMesh mesh = buildMesh(raw, r);
    if (mesh.triangles.empty()) {
        throw ParseError(where, "no usable triangles in this " + r.format + " file (" +
                                    std::to_string(r.facesRead) + " faces read, " +
                                    std::to_string(r.degenerateTrianglesDropped) + " degenerate)");
    }
    if (report) *report = std::move(r);
    return mesh;
}

// Mesh Export

void writeMeshObj(const std::filesystem::path& path, const TriangleMesh& mesh,
                  std::span<const int> objectOfTriangle, std::span<const std::string> objectNames) {
    checkObjectIds(mesh, objectOfTriangle, "writeMeshObj");
    writeAtomically(path, std::ios::binary, [&](std::ostream& out) {
        out.precision(17);
        out << "# veil mesh export: " << mesh.vertices.size() << " vertices, "
            << mesh.triangles.size() << " triangles, mm\n";
        for (const Vec3& v : mesh.vertices) out << "v " << v.x << ' ' << v.y << ' ' << v.z << '\n';
        bool first = true;
        int current = 0;
        for (size_t t = 0; t < mesh.triangles.size(); ++t) {
            if (!objectOfTriangle.empty() && (first || objectOfTriangle[t] != current)) {
                current = objectOfTriangle[t];
                out << "g " << objGroupName(current, objectNames) << '\n';
            }
            first = false;
            const auto& tri = mesh.triangles[t];
            out << "f " << tri[0] + 1 << ' ' << tri[1] + 1 << ' ' << tri[2] + 1 << '\n';
        }
    });
}

void writeMeshPly(const std::filesystem::path& path, const TriangleMesh& mesh,
                  std::span<const int> objectOfTriangle, PlyEncoding encoding) {
    checkObjectIds(mesh, objectOfTriangle, "writeMeshPly");
    const bool binary = encoding == PlyEncoding::BinaryLittleEndian;
    const bool ids = !objectOfTriangle.empty();
    writeAtomically(path, std::ios::binary, [&](std::ostream& out) {
        out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\n"
            << "comment veil mesh export, mm\n"
            << "element vertex " << mesh.vertices.size() << '\n'
            << "property double x\nproperty double y\nproperty double z\n"
            << "element face " << mesh.triangles.size() << '\n'
            << "property list uchar int vertex_indices\n"
            << (ids ? "property int object_id\n" : "") << "end_header\n";
        if (binary) {
            for (const Vec3& v : mesh.vertices)
                for (int a = 0; a < 3; ++a) putLittleEndian(out, v[a]);
            for (size_t t = 0; t < mesh.triangles.size(); ++t) {
                putLittleEndian(out, static_cast<uint8_t>(3));
                for (uint32_t i : mesh.triangles[t]) putLittleEndian(out, static_cast<int32_t>(i));
                if (ids) putLittleEndian(out, static_cast<int32_t>(objectOfTriangle[t]));
            }
        } else {
            out.precision(17);
            for (const Vec3& v : mesh.vertices) out << v.x << ' ' << v.y << ' ' << v.z << '\n';
            for (size_t t = 0; t < mesh.triangles.size(); ++t) {
                const auto& tri = mesh.triangles[t];
                out << "3 " << tri[0] << ' ' << tri[1] << ' ' << tri[2];
                if (ids) out << ' ' << objectOfTriangle[t];
                out << '\n';
            }
        }
    });
}

// Scene File Import

double meshUnitMm(const std::string& units) {
    if (units == "mm") return 1.0;
    if (units == "cm") return 10.0;
    if (units == "m") return 1000.0;
    if (units == "in") return 25.4;
    if (units == "um") return 1e-3;
    throw std::invalid_argument("unknown length unit '" + units + "'");
}

Frame MeshImportSpec::placement() const {
    Frame f;
    f.rotation =
        axisRotation(0, rotateDeg.x) * axisRotation(1, rotateDeg.y) * axisRotation(2, rotateDeg.z);
    f.translation = translateMm;
    return f;
}

std::ostream& operator<<(std::ostream& os, const MeshImportSpec& s) {
    return os << "MeshImportSpec{" << s.name << ", " << s.file.string() << ", " << s.units << " x "
              << s.scale << ", rotate_deg " << s.rotateDeg << ", translate_mm " << s.translateMm
              << (s.requireClosed ? ", closed required" : ", may be open")
              << (s.property.empty() ? "" : ", property " + s.property) << "}";
}

std::ostream& operator<<(std::ostream& os, const ImportedMesh& m) {
    os << "ImportedMesh{" << m.name;
    if (!m.property.empty()) os << ", property " << m.property;
    return os << ", " << m.mesh << ", " << m.report << ", " << m.notes.size() << " notes}";
}

std::vector<MeshImportSpec> readMeshImports(TomlDocument& doc) {
    std::vector<MeshImportSpec> specs;
    const std::optional<TomlValue> list = doc.root().get("mesh");
    if (!list) return specs;
    if (!list->isArray()) list->failExpected("an array of tables [[mesh]]");
    const std::filesystem::path sceneFolder = std::filesystem::path(doc.fileName()).parent_path();
    std::map<std::string, FileLoc> seen;
    for (const TomlValue& entry : list->asArray()) {
        if (!entry.isTable()) entry.failExpected("a table [[mesh]]");
        const TomlTable t = entry.asTable();
        MeshImportSpec s;
        s.loc = t.loc();

        const TomlValue name = t.require("name", "the object name used in reports and criteria");
        s.name = name.asString();
        if (s.name.empty()) name.fail(name.path() + " must not be empty");
        if (auto [it, inserted] = seen.emplace(s.name, name.loc()); !inserted)
            name.fail("mesh name '" + s.name + "' is already used at " + it->second.str());

        const TomlValue file = t.require("file", "path of an STL, OBJ, PLY or OFF file");
        const std::filesystem::path given = file.asString();
        s.fileLoc = file.loc();
        s.file = given.is_absolute() ? given : sceneFolder / given;
        if (!formatOf(s.file))
            file.fail("unknown mesh format '" + given.extension().string() +
                      "' (expected .stl, .obj, .ply or .off)");
        std::error_code ec;
        if (!std::filesystem::is_regular_file(s.file, ec))
            file.fail("mesh file '" + given.string() + "' not found (looked for " +
                      s.file.string() + ")");

        s.property = t.string("property", "");
        if (const std::optional<TomlValue> units = t.get("units")) {
            s.units = units->asString();
            try {
                meshUnitMm(s.units);
            } catch (const std::invalid_argument&) {
                units->fail("unknown units '" + s.units + "' (expected mm, cm, m, in or um)");
            }
        }
        s.scale = t.number("scale", 1.0, NumberRange::above(0.0));
        if (const std::optional<TomlValue> v = t.get("translate_mm")) s.translateMm = readVec3(*v);
        if (const std::optional<TomlValue> v = t.get("rotate_deg")) s.rotateDeg = readVec3(*v);
        s.requireClosed = t.boolean("require_closed", true);
        specs.push_back(std::move(s));
    }
    return specs;
}

ImportedMesh loadMeshImport(const MeshImportSpec& spec) {
    ImportedMesh out;
    out.name = spec.name;
    out.property = spec.property;
    try {
        out.mesh = readMeshFile(spec.file, &out.report);
    } catch (const ParseError& e) {
        throw ParseError(spec.fileLoc, "mesh '" + spec.name + "': " + e.what());
    }

    const double k = spec.mmPerFileUnit();
    const Frame placement = spec.placement();
    for (Vec3& v : out.mesh.vertices) v = placement.toGlobalPoint(k * v);
    out.report.signedVolume = signedVolumeOf(out.mesh);

    const std::string what = "mesh '" + spec.name + "' (" + spec.file.string() + ")";
    if (!out.report.isClosedSolid()) {
        const std::string message = what + " is not a closed solid: " + out.report.problems();
        if (spec.requireClosed)
            throw ParseError(spec.loc, message + " (set require_closed = false to accept it)");
        out.notes.push_back({ImportNote::Severity::Warning, spec.loc,
                             message + "; accepted because require_closed = false"});
    }
    if (out.report.orientationReversed) {
        out.notes.push_back({ImportNote::Severity::Info, spec.loc,
                             what + " was inside out (negative volume); its triangles were "
                                    "reversed so that normals point outward"});
    }
    return out;
}

}  // namespace veil
