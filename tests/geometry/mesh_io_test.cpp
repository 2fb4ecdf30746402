// Mesh import and export against meshes whose numbers are known by hand: a 10 mm cube in
// every format (volume 1000 mm^3, area 600 mm^2), an L-shaped prism with concave caps
// (volume 1500 mm^3, area 1000 mm^2), a box with its lid missing (4 boundary edges), a cube
// with one triangle reversed (3 inconsistent edges). Volumes and areas are recomputed here
// from the triangles, about the origin, independently of the reader's own report.
// The test meshes are in tests/data/mesh (README.md there lists them).

#include "geometry/mesh_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <set>
#include <sstream>
#include <tuple>

#include "lensdata/toml_document.h"

namespace veil {
namespace {

std::filesystem::path dataPath(const std::string& name) {
    return std::filesystem::path(VEIL_SOURCE_DIR) / "tests" / "data" / "mesh" / name;
}

// A fresh folder per test for files we write.
std::filesystem::path scratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::filesystem::path dir = std::filesystem::path(VEIL_BINARY_DIR) / "test_scratch" /
                                      "mesh_io" /
                                      (std::string(info->test_suite_name()) + "." + info->name());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

void writeText(const std::filesystem::path& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary);
    out << text;
}

std::string readText(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
}

// Oracles

double volumeAboutOrigin(const TriangleMesh& m) {
    double sum = 0.0;
    for (const auto& t : m.triangles)
        sum += glm::dot(m.vertices[t[0]], glm::cross(m.vertices[t[1]], m.vertices[t[2]]));
    return sum / 6.0;
}

double unsignedArea(const TriangleMesh& m) {
    double sum = 0.0;
    for (const auto& t : m.triangles)
        sum += 0.5 * glm::length(glm::cross(m.vertices[t[1]] - m.vertices[t[0]],
                                            m.vertices[t[2]] - m.vertices[t[0]]));
    return sum;
}

using Point = std::tuple<double, double, double>;
using Triangle = std::array<Point, 3>;

Point key(const Vec3& v) { return {v.x, v.y, v.z}; }

// The triangles as corner positions, each started at its smallest corner (orientation kept),
// sorted: equal for two meshes with the same triangles whatever their vertex numbering.
std::vector<Triangle> canonicalTriangles(const TriangleMesh& m) {
    std::vector<Triangle> out;
    for (const auto& t : m.triangles) {
        Triangle tri{key(m.vertices[t[0]]), key(m.vertices[t[1]]), key(m.vertices[t[2]])};
        std::rotate(tri.begin(), std::min_element(tri.begin(), tri.end()), tri.end());
        out.push_back(tri);
    }
    std::sort(out.begin(), out.end());
    return out;
}

std::set<Point> vertexSet(const TriangleMesh& m) {
    std::set<Point> s;
    for (const Vec3& v : m.vertices) s.insert(key(v));
    return s;
}

std::set<Point> cubeCorners(double side, Vec3 offset = Vec3(0.0)) {
    std::set<Point> s;
    for (int i = 0; i < 8; ++i)
        s.insert(key(offset + side * Vec3(i & 1, (i >> 1) & 1, (i >> 2) & 1)));
    return s;
}

// Every triangle's normal points away from `centre` (a convex solid around it).
bool normalsPointAwayFrom(const TriangleMesh& m, const Vec3& centre) {
    for (size_t t = 0; t < m.triangles.size(); ++t) {
        const auto& tri = m.triangles[t];
        const Vec3 c = (m.vertices[tri[0]] + m.vertices[tri[1]] + m.vertices[tri[2]]) / 3.0;
        if (!(glm::dot(m.triangleNormal(t), c - centre) > 0.0)) return false;
    }
    return true;
}

ParseError parseErrorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const ParseError& e) {
        return e;
    }
    ADD_FAILURE() << "no ParseError thrown";
    return ParseError({}, "");
}

// Reading

TEST(MeshIo, ClosedCubeReadsAlikeInEveryFormat) {
    struct Case {
        const char* file;
        const char* format;
        size_t faces;
        size_t polygons;
        size_t merged;
    };
    const Case cases[] = {
        {"cube_ascii.stl", "STL (ASCII)", 12, 0, 36 - 8},  // STL: 3 corners per facet
        {"cube_binary.stl", "STL (binary)", 12, 0, 36 - 8},
        {"cube_quads.obj", "OBJ", 6, 6, 0},
        {"cube_ascii.ply", "PLY (ASCII)", 12, 0, 0},
        {"cube_binary.ply", "PLY (binary)", 6, 6, 0},
        {"cube_quads.off", "OFF", 6, 6, 0},
    };
    const std::vector<Triangle> reference =
        canonicalTriangles(readMeshFile(dataPath("cube_ascii.stl")));
    for (const Case& c : cases) {
        SCOPED_TRACE(c.file);
        MeshReadReport r;
        const TriangleMesh m = readMeshFile(dataPath(c.file), &r);
        EXPECT_EQ(r.file, dataPath(c.file).string());
        EXPECT_EQ(r.format, c.format);
        EXPECT_EQ(m.vertices.size(), 8u);
        EXPECT_EQ(m.triangles.size(), 12u);
        EXPECT_EQ(r.vertices, 8u);
        EXPECT_EQ(r.triangles, 12u);
        EXPECT_EQ(r.facesRead, c.faces);
        EXPECT_EQ(r.polygonsTriangulated, c.polygons);
        EXPECT_EQ(r.duplicateVerticesMerged, c.merged);
        EXPECT_EQ(r.degenerateTrianglesDropped, 0u);
        EXPECT_EQ(r.unusedVerticesDropped, 0u);
        EXPECT_EQ(r.boundaryEdges, 0u);
        EXPECT_EQ(r.nonManifoldEdges, 0u);
        EXPECT_EQ(r.inconsistentEdges, 0u);
        EXPECT_EQ(r.nonManifoldVertices, 0u);
        EXPECT_TRUE(r.isClosedSolid()) << r;
        EXPECT_FALSE(r.orientationReversed);
        EXPECT_EQ(r.problems(), "");

        EXPECT_EQ(vertexSet(m), cubeCorners(10.0));
        const Bounds3 b = m.bounds();
        EXPECT_EQ(b.lo, Vec3(0.0));
        EXPECT_EQ(b.hi, Vec3(10.0));
        EXPECT_DOUBLE_EQ(volumeAboutOrigin(m), 1000.0);  // side^3
        EXPECT_DOUBLE_EQ(r.signedVolume, 1000.0);
        EXPECT_DOUBLE_EQ(unsignedArea(m), 600.0);
        EXPECT_TRUE(normalsPointAwayFrom(m, Vec3(5.0)));
        // Quads split into the same two triangles as the STL's facets.
        EXPECT_EQ(canonicalTriangles(m), reference);
    }
}

TEST(MeshIo, ReportPrintsItself) {
    MeshReadReport r;
    readMeshFile(dataPath("cube_binary.stl"), &r);
    std::ostringstream os;
    os << r;
    EXPECT_NE(os.str().find("STL (binary): 8 vertices, 12 triangles"), std::string::npos)
        << os.str();
    EXPECT_NE(os.str().find("closed solid, volume 1000"), std::string::npos) << os.str();
}

TEST(MeshIo, DegenerateStlFacetIsDroppedAndCounted) {
    // 12 cube facets plus one with two corners at the origin, which OpenMesh's STL reader
    // skips silently; our count of the file's facets gives it away.
    MeshReadReport r;
    const TriangleMesh m = readMeshFile(dataPath("cube_degenerate.stl"), &r);
    EXPECT_EQ(r.facesRead, 13u);
    EXPECT_EQ(r.degenerateTrianglesDropped, 1u);
    EXPECT_EQ(m.triangles.size(), 12u);
    EXPECT_EQ(r.duplicateVerticesMerged, 39u - 8u);
    EXPECT_TRUE(r.isClosedSolid()) << r;
    EXPECT_DOUBLE_EQ(volumeAboutOrigin(m), 1000.0);
}

TEST(MeshIo, VerticesSplitAtSeamsAreMerged) {
    MeshReadReport r;
    const TriangleMesh m = readMeshFile(dataPath("cube_split_vertices.obj"), &r);
    EXPECT_EQ(r.duplicateVerticesMerged, 16u);  // 24 written, 8 distinct
    EXPECT_EQ(m.vertices.size(), 8u);
    EXPECT_TRUE(r.isClosedSolid()) << r;
    EXPECT_EQ(canonicalTriangles(m), canonicalTriangles(readMeshFile(dataPath("cube_quads.obj"))));
}

TEST(MeshIo, ConcavePolygonsWithStraightCornersAreTriangulatedWithoutOverlap) {
    // Both caps are 7-gons of an L (area 300) with a corner at (10, 0) on a straight edge;
    // the top cap starts at (20, 0), from where a fan would leave the polygon. A fan from
    // the first corner would give a zero-area triangle and overlapping ones: the unsigned
    // area would exceed the true 1000 mm^2 and the mesh would not close.
    MeshReadReport r;
    const TriangleMesh m = readMeshFile(dataPath("l_prism.obj"), &r);
    EXPECT_EQ(r.polygonsTriangulated, 9u);
    EXPECT_EQ(r.degenerateTrianglesDropped, 0u);
    EXPECT_EQ(m.triangles.size(), 2u * 5u + 7u * 2u);
    EXPECT_TRUE(r.isClosedSolid()) << r;
    EXPECT_DOUBLE_EQ(volumeAboutOrigin(m), 1500.0);
    EXPECT_DOUBLE_EQ(unsignedArea(m), 1000.0);
    for (size_t t = 0; t < m.triangles.size(); ++t) {
        const auto& tri = m.triangles[t];
        const double z0 = m.vertices[tri[0]].z;
        if (z0 == m.vertices[tri[1]].z && z0 == m.vertices[tri[2]].z) {
            EXPECT_EQ(m.triangleNormal(t), Vec3(0.0, 0.0, z0 == 0.0 ? -1.0 : 1.0)) << t;
        }
    }
}

TEST(MeshIo, RandomStarPolygonsAreTriangulatedExactly) {
    // Random star-shaped polygons (simple, mostly concave, rarely fan-able from corner 0):
    // the triangles must cover the polygon exactly once, all facing +z: their unsigned areas
    // sum to the shoelace area and there are n - 2 of them. Coordinates are multiples of
    // 1/4096 so that OpenMesh's float parsing keeps them exact.
    const auto dir = scratchDir();
    std::mt19937 rng(20240611);
    std::uniform_real_distribution<double> radius(2.0, 10.0), unit(0.0, 1.0);
    int notFannable = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const int n = 4 + trial % 37;
        std::vector<double> angles;
        // Angles at least 0.02 rad apart: evenly spaced, each jittered by under a third.
        for (int i = 0; i < n; ++i)
            angles.push_back((i + 0.3 * (unit(rng) - 0.5)) * 2.0 * std::numbers::pi / n);
        std::vector<Vec2> poly;
        for (double a : angles) {
            const double r = radius(rng);
            poly.emplace_back(std::round(4096.0 * r * std::cos(a)) / 4096.0,
                              std::round(4096.0 * r * std::sin(a)) / 4096.0);
        }
        double shoelace = 0.0;
        for (int i = 0; i < n; ++i) {
            const Vec2& p = poly[i];
            const Vec2& q = poly[(i + 1) % n];
            shoelace += 0.5 * (p.x * q.y - q.x * p.y);
        }
        bool fanOk = true;  // would the fan from corner 0 do?
        for (int i = 1; i + 1 < n; ++i) {
            const Vec2 e1 = poly[i] - poly[0], e2 = poly[i + 1] - poly[0];
            fanOk = fanOk && e1.x * e2.y - e1.y * e2.x > 0.0;
        }
        notFannable += !fanOk;

        std::ostringstream obj;
        obj.precision(17);
        for (const Vec2& p : poly) obj << "v " << p.x << " " << p.y << " 0\n";
        obj << "f";
        for (int i = 1; i <= n; ++i) obj << " " << i;
        obj << "\n";
        writeText(dir / "star.obj", obj.str());
        MeshReadReport r;
        const TriangleMesh m = readMeshFile(dir / "star.obj", &r);
        SCOPED_TRACE(obj.str());
        ASSERT_EQ(m.triangles.size(), static_cast<size_t>(n - 2));
        EXPECT_EQ(r.degenerateTrianglesDropped, 0u);
        EXPECT_EQ(r.boundaryEdges, static_cast<size_t>(n));
        EXPECT_NEAR(unsignedArea(m), shoelace, 1e-12 * shoelace);
        for (size_t t = 0; t < m.triangles.size(); ++t)
            EXPECT_GT(m.triangleNormal(t).z, 0.0) << t;  // none reversed
    }
    EXPECT_GT(notFannable, 100);  // the test would catch a plain fan
}

TEST(MeshIo, OpenBoxIsReportedWithItsBoundaryEdges) {
    MeshReadReport r;
    const TriangleMesh m = readMeshFile(dataPath("open_box.obj"), &r);
    EXPECT_EQ(m.triangles.size(), 10u);
    EXPECT_EQ(r.boundaryEdges, 4u);  // the rim of the missing lid
    EXPECT_EQ(r.nonManifoldEdges, 0u);
    EXPECT_EQ(r.inconsistentEdges, 0u);
    EXPECT_FALSE(r.closed());
    EXPECT_TRUE(r.consistentlyOriented());
    EXPECT_FALSE(r.isClosedSolid());
    EXPECT_FALSE(r.orientationReversed);
    EXPECT_EQ(r.problems(), "open: 4 boundary edges");
}

TEST(MeshIo, FlippedTriangleIsReportedAsInconsistentOrientation) {
    // Its three edges are each shared with a neighbour running the same way. OpenMesh's own
    // halfedge mesh would split it off and call it 6 boundary edges.
    MeshReadReport r;
    const TriangleMesh m = readMeshFile(dataPath("flipped_triangle.off"), &r);
    EXPECT_EQ(m.triangles.size(), 12u);
    EXPECT_EQ(r.boundaryEdges, 0u);
    EXPECT_EQ(r.inconsistentEdges, 3u);
    EXPECT_TRUE(r.closed());
    EXPECT_FALSE(r.consistentlyOriented());
    EXPECT_FALSE(r.isClosedSolid());
    EXPECT_FALSE(r.orientationReversed);  // not turned around: it is not consistent
    EXPECT_NE(r.problems().find("inconsistent orientation: 3 edges"), std::string::npos)
        << r.problems();
}

std::string cubeObj(double side, Vec3 offset, int firstVertex, bool insideOut) {
    std::ostringstream os;
    for (int i = 0; i < 8; ++i) {
        const Vec3 p = offset + side * Vec3(i & 1, (i >> 1) & 1, (i >> 2) & 1);
        os << "v " << p.x << " " << p.y << " " << p.z << "\n";
    }
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                             {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        os << "f";
        for (int k = 0; k < 4; ++k) os << " " << firstVertex + q[insideOut ? 3 - k : k];
        os << "\n";
    }
    return os.str();
}

TEST(MeshIo, InsideOutClosedMeshIsTurnedAround) {
    const auto dir = scratchDir();
    writeText(dir / "inside_out.obj", cubeObj(10.0, Vec3(0.0), 1, true));
    MeshReadReport r;
    const TriangleMesh m = readMeshFile(dir / "inside_out.obj", &r);
    EXPECT_TRUE(r.isClosedSolid());
    EXPECT_TRUE(r.orientationReversed);
    EXPECT_DOUBLE_EQ(r.signedVolume, 1000.0);
    EXPECT_DOUBLE_EQ(volumeAboutOrigin(m), 1000.0);
    EXPECT_TRUE(normalsPointAwayFrom(m, Vec3(5.0)));
}

TEST(MeshIo, NonManifoldEdgesAndVerticesAreCounted) {
    const auto dir = scratchDir();
    // Two cubes touching at the corner (10, 10, 10): closed, one non-manifold vertex.
    writeText(dir / "corner.obj",
              cubeObj(10.0, Vec3(0.0), 1, false) + cubeObj(10.0, Vec3(10.0), 9, false));
    MeshReadReport corner;
    const TriangleMesh m = readMeshFile(dir / "corner.obj", &corner);
    EXPECT_EQ(corner.nonManifoldVertices, 1u);
    EXPECT_EQ(corner.nonManifoldEdges, 0u);
    EXPECT_TRUE(corner.isClosedSolid()) << corner;
    EXPECT_DOUBLE_EQ(volumeAboutOrigin(m), 2000.0);

    // Two cubes sharing the edge x = y = 10: four triangles on it.
    writeText(dir / "edge.obj",
              cubeObj(10.0, Vec3(0.0), 1, false) + cubeObj(10.0, Vec3(10.0, 10.0, 0.0), 9, false));
    MeshReadReport edge;
    readMeshFile(dir / "edge.obj", &edge);
    EXPECT_EQ(edge.nonManifoldEdges, 1u);
    EXPECT_EQ(edge.boundaryEdges, 0u);
    EXPECT_FALSE(edge.closed());
    EXPECT_NE(edge.problems().find("1 non-manifold edges"), std::string::npos) << edge;
}

TEST(MeshIo, UnreadableFilesAreParseErrorsNamingTheFile) {
    const auto dir = scratchDir();
    const std::string cubeStl = readText(dataPath("cube_ascii.stl"));
    const std::string cubeBinary = readText(dataPath("cube_binary.stl"));
    const std::string cubeOff = readText(dataPath("cube_quads.off"));
    const std::string triangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    std::string badNumber = cubeStl;
    badNumber.replace(badNumber.find("vertex 10 0 0"), 13, "vertex 10 0 zero");
    std::string outerName = cubeStl;
    outerName.replace(0, 10, "solid outer_tube");
    writeText(dir / "words.stl", "this is not\nan STL file\n");
    writeText(dir / "bad_number.stl", badNumber);
    writeText(dir / "outer.stl", outerName);
    writeText(dir / "truncated.stl", cubeBinary.substr(0, 300));
    writeText(dir / "truncated.off", cubeOff.substr(0, cubeOff.find("4 1 3 7 5")));
    writeText(dir / "comment.off", "OFF\n# a comment\n" + cubeOff.substr(4));
    writeText(dir / "index.obj", triangleObj + "f 1 2 7\n");
    writeText(dir / "zero.obj", triangleObj + "f 1 2 0\n");
    writeText(dir / "nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    writeText(dir / "part.step", "ISO-10303-21;\n");
    writeText(dir / "empty.obj", "# nothing\n");
    // A face of -3 corners: OpenMesh read it as 4294967293 and grew without end (issue 44's
    // 157-byte reproducer), in ASCII and binary.
    const std::string plyHead =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const std::string plyVertices = "0 0 0\n1 0 0\n0 1 0\n";
    writeText(dir / "minus.ply", plyHead + plyVertices + "-3 0 1 2\n");
    writeText(dir / "corner.ply", plyHead + plyVertices + "3 0 1 3\n");
    writeText(dir / "short.ply", plyHead + plyVertices + "4 0 1 2\n");
    writeText(dir / "cut.ply", plyHead + "0 0 0\n1 0 0\n");
    auto binaryPly = [&](int32_t count, uint32_t lastCorner) {
        std::string s =
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
            "property float y\nproperty float z\nelement face 1\n"
            "property list int int vertex_indices\nend_header\n";
        auto put = [&](const auto& v) { s.append(reinterpret_cast<const char*>(&v), sizeof v); };
        for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(v);
        put(count);
        for (uint32_t c : {0u, 1u, lastCorner}) put(c);
        return s;
    };
    writeText(dir / "minus_binary.ply", binaryPly(-3, 2));
    writeText(dir / "huge_binary.ply", binaryPly(1 << 20, 2));
    writeText(dir / "corner_binary.ply", binaryPly(3, 7));
    struct Case {
        std::filesystem::path file;
        int line;  // 0: OpenMesh tells no line, and neither can we
        int column;
        std::string reason;
    };
    const Case cases[] = {
        // OpenMesh's PLY header parser would allocate without end on this one.
        {dataPath("malformed.ply"), 3, 0,
         "expected 'element <name> <count>', got 'element vertex eight'"},
        {dataPath("bad_index.off"), 16, 9, "expected a vertex index from 0 to 7, got '8'"},
        {dataPath("no_such_file.stl"), 0, 0, "no such mesh file"},
        {dir / "words.stl", 0, 0, "no usable triangles in this STL (ASCII) file (0 faces read"},
        {dir / "bad_number.stl", 13, 19, "vertex: expected a finite number, got 'zero'"},
        {dir / "outer.stl", 1, 7, "takes every line containing 'outer' for the start of a facet"},
        {dir / "truncated.stl", 0, 0,
         "binary STL of 300 bytes, but its header announces 12 triangles, which take 84 + 50 x 12 "
         "= 684 bytes"},
        {dir / "truncated.off", 15, 0, "the file ends after 5 of its 6 faces"},
        {dir / "comment.off", 2, 1, "does not skip comment lines"},
        {dir / "index.obj", 0, 0,
         "face 1 refers to vertex 7 (counting from 1), but the file has 3 vertices"},
        {dir / "zero.obj", 4, 7, "expected a vertex number (from 1, or negative from the end)"},
        {dir / "nan.obj", 2, 5, "vertex: expected a finite number, got 'nan'"},
        {dir / "part.step", 0, 0, "unknown mesh format '.step'"},
        {dir / "empty.obj", 0, 0, "no usable triangles"},
        {dir / "minus.ply", 13, 1,
         "list 'vertex_indices' starts with its count (0 to 1048576), got '-3'"},
        {dir / "corner.ply", 13, 7, "expected a vertex index from 0 to 2, got '3'"},
        {dir / "short.ply", 13, 1,
         "list 'vertex_indices' announces 4 values, but the line holds 3"},
        {dir / "cut.ply", 11, 0, "the file ends after 2 of its 3 vertex elements"},
        {dir / "minus_binary.ply", 0, 0, "face 0: list 'vertex_indices' announces -3 values"},
        {dir / "huge_binary.ply", 0, 0, "the file ends inside face 0 of 1"},
        {dir / "corner_binary.ply", 0, 0, "face 0: vertex index 7 outside 0 to 2"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.file.string());
        ::testing::internal::CaptureStderr();
        const ParseError e = parseErrorOf([&] { readMeshFile(c.file); });
        const std::string printed = ::testing::internal::GetCapturedStderr();
        EXPECT_EQ(e.loc().file, c.file.string());
        EXPECT_EQ(e.loc().line, c.line) << e.what();
        EXPECT_EQ(e.loc().column, c.column) << e.what();
        EXPECT_NE(std::string(e.what()).find(c.file.string()), std::string::npos) << e.what();
        EXPECT_NE(e.message().find(c.reason), std::string::npos) << e.message();
        EXPECT_EQ(printed, "");  // OpenMesh's complaints are caught, not printed
    }
}

// Writing

TriangleMesh rotatedLPrism() {
    // Coordinates that are not round numbers, so the round trip tests the digits written.
    MeshImportSpec s;
    s.rotateDeg = Vec3(30.0, -20.0, 10.0);
    s.translateMm = Vec3(1.0 / 3.0, -2.5, 100.0);
    TriangleMesh m = readMeshFile(dataPath("l_prism.obj"));
    m.transform(s.placement());
    return m;
}

// OpenMesh parses coordinates as floats: each comes back as the float nearest to what we
// wrote (17 digits or a double), within 2^-24 of its size and no further.
void expectSameMesh(const TriangleMesh& a, const TriangleMesh& b) {
    ASSERT_EQ(a.vertices.size(), b.vertices.size());
    ASSERT_EQ(a.triangles.size(), b.triangles.size());
    for (size_t v = 0; v < a.vertices.size(); ++v) {
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(b.vertices[v][k], static_cast<double>(static_cast<float>(a.vertices[v][k])))
                << v;
            EXPECT_LE(std::abs(b.vertices[v][k] - a.vertices[v][k]),
                      std::ldexp(std::abs(a.vertices[v][k]), -24));
        }
    }
    EXPECT_EQ(a.triangles, b.triangles);  // same order, same numbering
}

TEST(MeshIo, ObjRoundTripKeepsTheMeshAndWritesGroups) {
    const auto dir = scratchDir();
    const TriangleMesh m = rotatedLPrism();
    std::vector<int> ids(m.triangles.size(), 4);
    for (size_t t = 10; t < ids.size(); ++t) ids[t] = 7;
    const std::vector<std::string> names = {"a",        "b", "c", "d",
                                            "L1.front", "e", "f", "barrel ring"};
    writeMeshObj(dir / "out.obj", m, ids, names);
    EXPECT_FALSE(std::filesystem::exists(dir / "out.obj.tmp"));

    MeshReadReport r;
    const TriangleMesh back = readMeshFile(dir / "out.obj", &r);
    expectSameMesh(m, back);
    EXPECT_TRUE(r.isClosedSolid()) << r;
    EXPECT_NEAR(r.signedVolume, 1500.0, 1e-3);

    const std::string text = readText(dir / "out.obj");
    EXPECT_NE(text.find("\ng L1.front\nf 1 2 3\n"), std::string::npos);
    EXPECT_NE(text.find("\ng barrel_ring\n"), std::string::npos);
    size_t groups = 0;
    for (size_t at = text.find("\ng "); at != std::string::npos; at = text.find("\ng ", at + 1))
        ++groups;
    EXPECT_EQ(groups, 2u);

    // Without names, groups are called by their ids; without ids there are none.
    writeMeshObj(dir / "ids.obj", m, ids);
    EXPECT_NE(readText(dir / "ids.obj").find("\ng object7\n"), std::string::npos);
    writeMeshObj(dir / "plain.obj", m);
    EXPECT_EQ(readText(dir / "plain.obj").find("\ng "), std::string::npos);
}

TEST(MeshIo, PlyRoundTripKeepsTheMeshInBothEncodings) {
    const auto dir = scratchDir();
    const TriangleMesh m = rotatedLPrism();
    std::vector<int> ids(m.triangles.size());
    for (size_t t = 0; t < ids.size(); ++t) ids[t] = static_cast<int>(t % 3);
    for (PlyEncoding enc : {PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian}) {
        const bool binary = enc == PlyEncoding::BinaryLittleEndian;
        SCOPED_TRACE(binary ? "binary" : "ascii");
        const auto path = dir / (binary ? "binary.ply" : "ascii.ply");
        writeMeshPly(path, m, ids, enc);
        MeshReadReport r;
        const TriangleMesh back = readMeshFile(path, &r);
        EXPECT_EQ(r.format, binary ? "PLY (binary)" : "PLY (ASCII)");
        expectSameMesh(m, back);
        EXPECT_TRUE(r.isClosedSolid()) << r;

        const std::string text = readText(path);
        EXPECT_NE(text.find("property int object_id\nend_header\n"), std::string::npos);
        if (!binary) {
            EXPECT_NE(text.find("\n3 0 1 2 0\n"), std::string::npos);
        }
    }
    // Without ids the property is not declared.
    writeMeshPly(dir / "plain.ply", m);
    EXPECT_EQ(readText(dir / "plain.ply").find("object_id"), std::string::npos);
    expectSameMesh(m, readMeshFile(dir / "plain.ply"));
}

TEST(MeshIo, FailedWriteLeavesNoFile) {
    const auto dir = scratchDir();
    const TriangleMesh m = readMeshFile(dataPath("cube_quads.obj"));
    EXPECT_THROW(writeMeshObj(dir / "missing_folder" / "x.obj", m), std::runtime_error);
    EXPECT_THROW(writeMeshPly(dir / "missing_folder" / "x.ply", m), std::runtime_error);
    // The message says why, as the system does (it had only said "write failed").
    try {
        writeMeshObj(dir / "missing_folder" / "x.obj", m);
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("No such file or directory"), std::string::npos)
            << e.what();
    }
    EXPECT_TRUE(std::filesystem::is_empty(dir));
    const std::vector<int> tooFew = {1, 2};
    EXPECT_THROW(writeMeshObj(dir / "x.obj", m, tooFew), std::invalid_argument);
    EXPECT_TRUE(std::filesystem::is_empty(dir));
}

// Scene File Import

std::vector<MeshImportSpec> readSpecs(const std::string& toml) {
    // The document claims to live in tests/data/mesh, so `file` is found there.
    TomlDocument doc = TomlDocument::fromString(toml, dataPath("scene.toml").string());
    std::vector<MeshImportSpec> specs = readMeshImports(doc);
    doc.checkAllUsed();
    return specs;
}

TEST(MeshImport, ReadsEveryKey) {
    const auto specs = readSpecs(R"([[mesh]]
name = "housing"
file = "cube_binary.stl"
property = "black_anodized"
units = "in"
scale = 0.5
translate_mm = [1, 2.5, -3]
rotate_deg = [90, 0, 45]
require_closed = false

[[mesh]]
name = "lid"
file = "cube_quads.obj"
)");
    ASSERT_EQ(specs.size(), 2u);
    const MeshImportSpec& a = specs[0];
    EXPECT_EQ(a.name, "housing");
    EXPECT_EQ(a.file, dataPath("cube_binary.stl"));
    EXPECT_EQ(a.property, "black_anodized");
    EXPECT_EQ(a.units, "in");
    EXPECT_EQ(a.scale, 0.5);
    EXPECT_DOUBLE_EQ(a.mmPerFileUnit(), 12.7);
    EXPECT_EQ(a.translateMm, Vec3(1.0, 2.5, -3.0));
    EXPECT_EQ(a.rotateDeg, Vec3(90.0, 0.0, 45.0));
    EXPECT_FALSE(a.requireClosed);
    EXPECT_EQ(a.loc.line, 1);
    EXPECT_EQ(a.fileLoc.line, 3);
    const MeshImportSpec& b = specs[1];  // defaults
    EXPECT_EQ(b.property, "");
    EXPECT_EQ(b.units, "mm");
    EXPECT_EQ(b.scale, 1.0);
    EXPECT_EQ(b.translateMm, Vec3(0.0));
    EXPECT_EQ(b.rotateDeg, Vec3(0.0));
    EXPECT_TRUE(b.requireClosed);
    std::ostringstream os;
    os << a;
    EXPECT_NE(os.str().find("housing"), std::string::npos);
}

TEST(MeshImport, NoMeshTableGivesNoImports) {
    TomlDocument doc = TomlDocument::fromString("x = 1\n", dataPath("scene.toml").string());
    EXPECT_TRUE(readMeshImports(doc).empty());
}

TEST(MeshImport, UnitsAndScaleConvertToMillimetres) {
    struct Case {
        const char* units;
        double scale;
        double sideMm;
    };
    const Case cases[] = {{"mm", 1.0, 10.0},  {"cm", 1.0, 100.0}, {"m", 1.0, 10000.0},
                          {"in", 1.0, 254.0}, {"um", 1.0, 0.01},  {"mm", 2.5, 25.0},
                          {"in", 0.1, 25.4}};
    for (const Case& c : cases) {
        SCOPED_TRACE(std::string(c.units) + " x " + std::to_string(c.scale));
        const auto specs = readSpecs(
            "[[mesh]]\nname = \"cube\"\nfile = \"cube_quads.off\"\n"
            "units = \"" +
            std::string(c.units) + "\"\nscale = " + std::to_string(c.scale) + "\n");
        const ImportedMesh im = loadMeshImport(specs.at(0));
        const Bounds3 b = im.mesh.bounds();
        EXPECT_EQ(b.lo, Vec3(0.0));
        for (int a = 0; a < 3; ++a) EXPECT_NEAR(b.hi[a], c.sideMm, 1e-12 * c.sideMm);
        const double volume = c.sideMm * c.sideMm * c.sideMm;
        EXPECT_NEAR(im.report.signedVolume, volume, 1e-12 * volume);
        EXPECT_NEAR(volumeAboutOrigin(im.mesh), volume, 1e-12 * volume);
    }
}

// p -> translate + Rx(rx) Ry(ry) Rz(rz) p, each right-handed; worked out by hand for the
// cube corners (0 or 10 on each axis).
TEST(MeshImport, PlacementRotatesIntrinsicXYZThenTranslates) {
    struct Case {
        Vec3 rotateDeg;
        Vec3 translateMm;
        Vec3 (*expected)(const Vec3&);  // corner of the file -> global position
    };
    const Case cases[] = {
        {{90, 0, 0}, {0, 0, 0}, [](const Vec3& p) { return Vec3(p.x, -p.z, p.y); }},
        {{0, 90, 0}, {0, 0, 0}, [](const Vec3& p) { return Vec3(p.z, p.y, -p.x); }},
        {{0, 0, 90}, {0, 0, 0}, [](const Vec3& p) { return Vec3(-p.y, p.x, p.z); }},
        // Ry(90) first sends p to (z, y, -x), then Rx(90) sends that to (z, x, y); the
        // other order would give (y, -z, -x).
        {{90, 90, 0}, {100, 0, -5}, [](const Vec3& p) { return Vec3(p.z + 100, p.x, p.y - 5); }},
        {{0, 0, 180}, {1, 2, 3}, [](const Vec3& p) { return Vec3(1 - p.x, 2 - p.y, 3 + p.z); }},
        {{-90, 0, 0}, {0, 0, 0}, [](const Vec3& p) { return Vec3(p.x, p.z, -p.y); }},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(::testing::Message() << "rotate_deg " << c.rotateDeg);
        std::ostringstream toml;
        toml << "[[mesh]]\nname = \"cube\"\nfile = \"cube_quads.obj\"\n"
             << "rotate_deg = [" << c.rotateDeg.x << ", " << c.rotateDeg.y << ", " << c.rotateDeg.z
             << "]\ntranslate_mm = [" << c.translateMm.x << ", " << c.translateMm.y << ", "
             << c.translateMm.z << "]\n";
        const MeshImportSpec spec = readSpecs(toml.str()).at(0);
        const TriangleMesh file = readMeshFile(spec.file);
        const ImportedMesh im = loadMeshImport(spec);
        ASSERT_EQ(im.mesh.vertices.size(), file.vertices.size());
        for (size_t v = 0; v < file.vertices.size(); ++v)
            EXPECT_EQ(im.mesh.vertices[v], c.expected(file.vertices[v])) << file.vertices[v];
        EXPECT_EQ(im.mesh.triangles, file.triangles);
        // A rotation keeps the volume and the outward normals.
        EXPECT_DOUBLE_EQ(volumeAboutOrigin(im.mesh), 1000.0);
        EXPECT_FALSE(im.report.orientationReversed);
    }

    // An angle that is not a quarter turn: 30 degrees about z.
    MeshImportSpec s;
    s.rotateDeg = Vec3(0.0, 0.0, 30.0);
    const Vec3 p = s.placement().toGlobalPoint(Vec3(10.0, 0.0, 0.0));
    EXPECT_NEAR(p.x, 5.0 * std::sqrt(3.0), 1e-14);
    EXPECT_NEAR(p.y, 5.0, 1e-14);
    EXPECT_EQ(p.z, 0.0);
}

TEST(MeshImport, OpenMeshIsAnErrorUnlessAllowed) {
    const std::string entry =
        "# an open box\n[[mesh]]\nname = \"box\"\nfile = \"open_box.obj\"\nproperty = \"black\"\n";
    const ParseError e = parseErrorOf([&] { loadMeshImport(readSpecs(entry).at(0)); });
    EXPECT_EQ(e.loc().file, dataPath("scene.toml").string());
    EXPECT_EQ(e.loc().line, 2);  // the [[mesh]] entry
    EXPECT_NE(e.message().find(dataPath("open_box.obj").string()), std::string::npos)
        << e.message();
    EXPECT_NE(e.message().find("open: 4 boundary edges"), std::string::npos) << e.message();
    EXPECT_NE(e.message().find("require_closed = false"), std::string::npos) << e.message();

    const ImportedMesh im = loadMeshImport(readSpecs(entry + "require_closed = false\n").at(0));
    EXPECT_EQ(im.name, "box");
    EXPECT_EQ(im.property, "black");
    EXPECT_EQ(im.report.boundaryEdges, 4u);
    ASSERT_EQ(im.notes.size(), 1u);
    EXPECT_EQ(im.notes[0].severity, ImportNote::Severity::Warning);
    EXPECT_EQ(im.notes[0].loc.line, 2);
    EXPECT_NE(im.notes[0].message.find("4 boundary edges"), std::string::npos);
    EXPECT_NE(im.notes[0].message.find("open_box.obj"), std::string::npos);

    // Inconsistent orientation is refused alike.
    const ParseError flipped = parseErrorOf([&] {
        loadMeshImport(
            readSpecs("[[mesh]]\nname = \"f\"\nfile = \"flipped_triangle.off\"\n").at(0));
    });
    EXPECT_NE(flipped.message().find("inconsistent orientation"), std::string::npos);
}

TEST(MeshImport, UnreadableMeshFileIsReportedAtTheFileKey) {
    const ParseError e = parseErrorOf([] {
        loadMeshImport(readSpecs("[[mesh]]\nname = \"m\"\nfile = \"malformed.ply\"\n").at(0));
    });
    EXPECT_EQ(e.loc().line, 3);
    EXPECT_NE(e.message().find("malformed.ply"), std::string::npos) << e.message();
}

TEST(MeshImport, BadEntriesAreParseErrorsAtTheKey) {
    struct Case {
        std::string toml;
        int line;
        std::string message;
    };
    const std::string head = "[[mesh]]\nname = \"a\"\nfile = \"cube_quads.obj\"\n";
    const Case cases[] = {
        {"[[mesh]]\nfile = \"cube_quads.obj\"\n", 1, "missing key 'name'"},
        {"[[mesh]]\nname = \"a\"\n", 1, "missing key 'file'"},
        {"[[mesh]]\nname = \"\"\nfile = \"cube_quads.obj\"\n", 2, "must not be empty"},
        {head + "[[mesh]]\nname = \"a\"\nfile = \"open_box.obj\"\n", 5,
         "mesh name 'a' is already used at"},
        {"[[mesh]]\nname = \"a\"\nfile = \"nowhere.stl\"\n", 3,
         "mesh file 'nowhere.stl' not found"},
        {"[[mesh]]\nname = \"a\"\nfile = \"part.step\"\n", 3, "unknown mesh format '.step'"},
        {head + "units = \"ft\"\n", 4, "unknown units 'ft' (expected mm, cm, m, in or um)"},
        {head + "scale = 0\n", 4, "must be > 0"},
        {head + "translate_mm = [1, 2]\n", 4, "must have 3 numbers"},
        {head + "rotate_deg = 90\n", 4, "an array of 3 numbers"},
        {head + "rotate_deg = [0, \"x\", 0]\n", 4, "number"},
        {head + "require_closed = \"yes\"\n", 4, "must be true or false"},
        {head + "rotate = [0, 0, 90]\n", 4, "did you mean 'rotate_deg'"},
        {"mesh = 3\n", 1, "array of tables"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.toml);
        const ParseError e = parseErrorOf([&] { readSpecs(c.toml); });
        EXPECT_EQ(e.loc().line, c.line) << e.what();
        EXPECT_NE(e.message().find(c.message), std::string::npos) << e.what();
    }
}

TEST(MeshImport, ImportedMeshPrintsItself) {
    const ImportedMesh im =
        loadMeshImport(readSpecs("[[mesh]]\nname = \"cube\"\nfile = \"cube_quads.obj\"\n").at(0));
    std::ostringstream os;
    os << im;
    EXPECT_NE(os.str().find("ImportedMesh{cube"), std::string::npos) << os.str();
    EXPECT_TRUE(im.notes.empty());
}

}  // namespace
}  // namespace veil
