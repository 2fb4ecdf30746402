#pragma once
// CAD import and scene export of triangle meshes.
//
// Reading goes through OpenMesh's file readers (STL ASCII and binary, OBJ, PLY ASCII and
// binary, OFF), which hand every vertex and face to an importer of ours. We keep the raw
// face list instead of letting OpenMesh build its halfedge structure, because that structure
// cannot hold the defects we must report: OpenMesh splits a face that would make an edge
// non-manifold or flip the orientation into a separate piece, which would turn a flipped
// triangle into "6 boundary edges". On the raw list we
//
//   1. merge vertices at exactly equal positions (exporters split vertices at normal or
//      texture seams; STL stores every corner of every facet),
//   2. split polygons into triangles by ear clipping (a convex polygon becomes the fan from
//      its first corner, as in OpenMesh's TriMesh; concave ones and corners on a straight
//      edge are handled too),
//   3. drop degenerate triangles (two corners at one position, or exactly zero area) and
//      vertices no triangle uses,
//   4. count the edges used by one triangle (boundary), by more than two (non-manifold), and
//      by two triangles running the same way (inconsistent orientation), and the vertices
//      whose triangles form several fans (non-manifold vertices),
//   5. turn a closed, consistently oriented mesh that is inside out (negative volume) the
//      right way round, so normals point outward as TriangleMesh promises.
//
// Nothing is repaired beyond that: open or inconsistent meshes are returned as read and the
// MeshReadReport says what is wrong. The scene's [[mesh]] reader (below) turns such a report
// into an error, or into a warning when the entry says require_closed = false.
//
// Precision: OpenMesh's readers parse coordinates as single-precision floats, so imported
// coordinates carry float rounding (about 1e-7 relative; binary STL is float by definition).
// Units and placement are applied afterwards in double precision.
//
// Scene file table, documented for users in docs/format.md:
//
//   [[mesh]]
//   name = "baffle"            # required, unique among the [[mesh]] entries
//   file = "cad/baffle.stl"    # relative to the scene file's folder
//   property = "black_anodized"
//   units = "in"               # mm (default), cm, m, in, um
//   scale = 1.0                # extra factor, > 0
//   translate_mm = [0, 0, 120]
//   rotate_deg = [90, 0, 0]    # intrinsic X, then Y', then Z'': R = Rx(rx) Ry(ry) Rz(rz)
//   require_closed = true
//
// global_mm = translate_mm + Rx(rx) Ry(ry) Rz(rz) (units_mm * scale * p_file)

#include <cstddef>
#include <filesystem>
#include <ostream>
#include <span>
#include <string>
#include <vector>

#include "geometry/triangle_mesh.h"
#include "lensdata/errors.h"
#include "lensdata/prescription.h"

namespace veil {

class TomlDocument;

// What reading a mesh file found. Counts refer to the returned mesh unless stated.
struct MeshReadReport {
    std::string file;
    std::string format;  // "STL (ASCII)", "STL (binary)", "OBJ", "PLY", "OFF"

    size_t vertices = 0;
    size_t triangles = 0;
    size_t facesRead = 0;             // faces (facets, polygons) in the file
    size_t polygonsTriangulated = 0;  // faces with more than 3 corners, split into fans
    // Corners that pointed at a position another vertex already had. For STL, which stores
    // every corner of every facet, this is 3 x facets minus the distinct positions.
    size_t duplicateVerticesMerged = 0;
    size_t unusedVerticesDropped = 0;
    size_t degenerateTrianglesDropped = 0;  // two corners at one position, or zero area

    size_t boundaryEdges = 0;        // used by one triangle: the mesh is open there
    size_t nonManifoldEdges = 0;     // used by three or more triangles
    size_t inconsistentEdges = 0;    // used by two triangles that run along it the same way
    size_t nonManifoldVertices = 0;  // triangles around it form several fans (touching shells)
    // The mesh was closed and consistent but inside out; every triangle was reversed.
    bool orientationReversed = false;
    // Signed volume enclosed (units of the mesh cubed): positive for a closed, outward
    // oriented mesh; meaningless for an open one.
    double signedVolume = 0.0;

    // Every edge shared by exactly two triangles.
    bool closed() const { return boundaryEdges == 0 && nonManifoldEdges == 0; }
    bool consistentlyOriented() const { return inconsistentEdges == 0; }
    // What require_closed asks for: closed and consistently oriented. Non-manifold vertices
    // (shells touching at a point) still bound a volume and are allowed.
    bool isClosedSolid() const { return closed() && consistentlyOriented(); }
    // "open: 4 boundary edges; inconsistent orientation: 3 edges", empty for a closed solid.
    std::string problems() const;
};
std::ostream& operator<<(std::ostream& os, const MeshReadReport& r);

// Reads a mesh in the units of the file, without placement. The format follows the
// extension (.stl, .obj, .ply, .off, any case). A file that is missing, of unknown type,
// malformed, truncated, or without a single usable triangle is a ParseError naming the file.
// OpenMesh tells no lines, and its readers turn most defects into silent zeros, so each file
// is first checked line by line against what its reader expects; those errors carry the
// line and column. Open or inconsistent meshes are returned; see the report. `report` may be
// null.
TriangleMesh readMeshFile(const std::filesystem::path& path, MeshReadReport* report = nullptr);

// Mesh Export
//
// For viewing the scene in other tools. Both writers take an optional object id per
// triangle (empty span: no grouping). OBJ gets a group line `g <name>` wherever the object
// changes, the name taken from objectNames[id] (whitespace replaced by '_'), or
// "object<id>" when no name is given. PLY gets a face property `int object_id`. Files are
// written under a temporary name in the same folder and renamed into place, so a failure
// never leaves a half-written file; failures throw std::runtime_error naming the file.
// Coordinates are written with 17 significant digits (OBJ, ASCII PLY) or as doubles
// (binary PLY).
void writeMeshObj(const std::filesystem::path& path, const TriangleMesh& mesh,
                  std::span<const int> objectOfTriangle = {},
                  std::span<const std::string> objectNames = {});
enum class PlyEncoding { Ascii, BinaryLittleEndian };
void writeMeshPly(const std::filesystem::path& path, const TriangleMesh& mesh,
                  std::span<const int> objectOfTriangle = {},
                  PlyEncoding encoding = PlyEncoding::BinaryLittleEndian);

// Scene File Import

// Length units a [[mesh]] file may be in, as mm per unit: "mm" 1, "cm" 10, "m" 1000,
// "in" 25.4, "um" 0.001. Throws std::invalid_argument for other names.
double meshUnitMm(const std::string& units);

// One [[mesh]] entry, checked but not yet loaded.
struct MeshImportSpec {
    std::string name;
    std::string property;        // empty: the scene default for imported meshes
    std::filesystem::path file;  // resolved against the scene file's folder
    std::string units = "mm";
    double scale = 1.0;     // extra factor on top of the units
    Vec3 translateMm{0.0};  // global, applied last
    Vec3 rotateDeg{0.0};    // intrinsic X, Y', Z'' (see placement())
    bool requireClosed = true;
    FileLoc loc;      // the [[mesh]] entry, for errors about the mesh
    FileLoc fileLoc;  // its `file` value, for errors reading the file

    // mm per file unit times scale.
    double mmPerFileUnit() const { return meshUnitMm(units) * scale; }
    // global = rotation * (mmPerFileUnit() * p) + translation, with rotation =
    // Rx(rx) Ry(ry) Rz(rz): right-handed rotations (counter-clockwise looking from the
    // positive axis toward the origin), about X first, then about the new Y, then about the
    // new Z. The same matrix read right to left is extrinsic: Z, then Y, then X, about the
    // fixed global axes.
    Frame placement() const;
};
std::ostream& operator<<(std::ostream& os, const MeshImportSpec& s);

// Reads every [[mesh]] entry of the scene (none when the table is absent), marking its keys
// used for TomlDocument::checkAllUsed(). ParseErrors at the key at fault: missing name or
// file, a name used twice, unknown units, scale <= 0, vectors that are not 3 numbers, a file
// that does not exist.
std::vector<MeshImportSpec> readMeshImports(TomlDocument& doc);

struct ImportedMesh {
    std::string name;
    std::string property;
    TriangleMesh mesh;              // global coordinates, mm, placed
    MeshReadReport report;          // signedVolume in mm^3
    std::vector<ImportNote> notes;  // warnings for a mesh accepted with require_closed = false
};
std::ostream& operator<<(std::ostream& os, const ImportedMesh& m);

// Reads the file, converts units and places the mesh. A file that cannot be read is a
// ParseError at the entry's `file` value that names the mesh file and the reason. A mesh
// that is not a closed solid (MeshReadReport::isClosedSolid) is a ParseError at the entry
// naming the file and the boundary edge count, unless require_closed = false, which turns
// it into a warning note.
ImportedMesh loadMeshImport(const MeshImportSpec& spec);

}  // namespace veil
