#pragma once
// The 3D scene the nonsequential tracer flies through: one object table for exact lens
// faces, mechanical parts, imported meshes and detectors, and closest-hit queries over all
// of them.
//
// Every object has a stable name users type in criteria and reports (L4.front, L4.edge,
// L4.flat1, stop, stop.edge, spacer3, barrel, sensor), a numeric id (its index), a kind, the
// name of its optical property (resolved by the tracer), and the media on its two sides:
// mediumFront is where the face normal points, mediumBack the other side. A ray meeting a
// face with direction . normal < 0 comes from the front medium and enters the back one.
// Opaque parts (mechanics, meshes) have air on both sides; their property decides what
// happens.
//
// Closest hit: exact faces are intersected analytically in double precision (the axis-band
// sweep of face_index.h); triangle meshes go through Embree (float) for candidates, refined
// in double on the candidate triangle. A ray that starts on an object passes that object (and for
// meshes the triangle) so the start point is not found again: no epsilon offsets.
//
// Sealed media. A lens element's glass is a closed body bounded by exact faces alone
// (addExactBody(), registered by addLensSolids()). commit() proves, for every body, that no
// mesh triangle comes near it: in the body's (r, z) half-plane each triangle's box (its
// exact distance range from the axis, its z range) is compared with an enclosure of the body
// at those radii, with a margin. A medium whose bodies are all clear, and which no mesh
// borders, is sealed: a ray travelling in it (closestHit()'s `medium`) starts inside one of
// its bodies and leaves it through an exact face before it could meet any triangle, so the
// query searches the exact faces alone and skips the triangle BVH. The answer is the same.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <variant>
#include <vector>

#include "geometry/exact_face.h"
#include "geometry/triangle_mesh.h"
#include "lensdata/prescription.h"

namespace veil {

enum class ObjectKind {
    LensFace,      // refracting face of a lens element (front, back, cemented)
    MirrorFace,    // reflecting optical surface
    LensEdge,      // butt end (cylinder) of a lens element
    LensFlat,      // flat annular shoulder between clear and mechanical aperture
    Stop,          // aperture stop plate (its faces) and its edge
    Mechanics,     // barrel, seats, retainers, spacers, baffles, vanes, field stop
    ImportedMesh,  // CAD import
    Detector,      // image sensor or any detector surface
    Dummy,         // a sequential surface with no physical part (kept for naming)
};
std::string_view toString(ObjectKind k);
std::ostream& operator<<(std::ostream& os, ObjectKind k);

struct Medium {
    std::string name;   // "air", a glass name, or a model glass label
    Material material;  // resolved to indices by the tracer
};

// A named group of triangles of one mesh. A closed part can be split into several named
// objects (the stop plate and its edge, stop and stop.edge) that together close it.
struct MeshRef {
    int mesh = 0;  // index into Scene::meshes()
    uint32_t firstTriangle = 0;
    uint32_t triangleCount = 0;  // 0 = all triangles from firstTriangle on
};

struct SceneObject {
    int id = -1;
    std::string name;
    std::vector<std::string> aliases;  // other names it answers to (L3.front for L2.back)
    ObjectKind kind = ObjectKind::Dummy;
    std::string part;      // the part it belongs to: "L4", "barrel", "spacer3", "stop"
    std::string property;  // optical property name; empty = the scene default for its kind
    int mediumFront = 0;   // index into Scene::media(); 0 is the ambient air
    int mediumBack = 0;
    Frame frame;  // exact faces: local to global; meshes are stored in global coords
    std::variant<FaceGeometry, MeshRef> geometry;
    int sequentialSurface = -1;  // prescription surface index for optical faces, else -1
};
std::ostream& operator<<(std::ostream& os, const SceneObject& o);

struct SceneHit {
    int object = -1;
    int primitive = 0;  // triangle index within its mesh, 0 for exact faces
    double t = 0.0;
    Vec3 point{0.0};        // global
    Vec3 normal{0.0};       // global, unit, the object's orientation (not flipped toward the ray)
    bool fromFront = true;  // the ray arrived from the side the normal points to
    int mediumFrom = 0;     // medium the ray travelled in
    int mediumTo = 0;       // medium on the other side
};
std::ostream& operator<<(std::ostream& os, const SceneHit& h);

// A closed region of one medium bounded by exact faces alone (a lens element's glass), as a
// solid of revolution about its frame's local z axis.
struct ExactBody {
    std::string part;       // the part whose faces bound it ("L4")
    int medium = 0;         // the medium inside (index into Scene::media())
    Frame frame;            // local to global; the axis is the local z axis
    double radiusMm = 0.0;  // no point of the body lies farther from the axis
    // For radii [r0, r1] within [0, radiusMm]: a local z interval holding every point of the
    // body at those radii (an enclosure, not a sample).
    std::function<void(double r0, double r1, double& zLo, double& zHi)> zRange;
};

class EmbreeScene;  // geometry/embree_scene.h

class Scene {
  public:
    Scene();
    ~Scene();
    Scene(Scene&&) noexcept;
    Scene& operator=(Scene&&) noexcept;

    // Building. Names must be unique (aliases included): a clash is a ModelError naming both.
    int addMedium(Medium m);  // returns its index; "air" is medium 0 from the start
    int addMesh(TriangleMesh mesh);
    int addObject(SceneObject o);  // assigns the id
    // A body of one medium bounded by the exact faces of `part` (see the top of this file).
    void addExactBody(ExactBody body);
    // Builds the acceleration structures. Must be called after the last add and before
    // any query; adding after commit() requires another commit().
    void commit();

    const std::vector<SceneObject>& objects() const { return objects_; }
    const SceneObject& object(int id) const { return objects_[id]; }
    const std::vector<Medium>& media() const { return media_; }
    const std::vector<TriangleMesh>& meshes() const { return meshes_; }
    // Object by name or alias; nullptr if none.
    const SceneObject* find(const std::string& name) const;
    Bounds3 bounds() const;

    // Closest hit with t in (0, tMax]. startObject/startPrimitive: the object (and mesh
    // triangle) the ray starts on, or -1. medium: the medium the ray travels in, or -1 when
    // unknown; in a sealed medium only the exact faces are searched (same answer, faster).
    std::optional<SceneHit> closestHit(const Ray& ray, double tMax = kInfinity,
                                       int startObject = -1, int startPrimitive = -1,
                                       int medium = -1) const;
    // Where the ray first meets one object's exact face with t in (0, tMax], whatever lies
    // before it (a sequential trace: the face alone, as if nothing else were in the scene);
    // startObject: the object the ray starts on, its own root at t ~ 0 skipped. Where
    // closestHit() meets that face first the hit is its hit: bit for bit on a plane, sphere,
    // conic or cylinder, to the root search's tolerance on other shapes (closestHit() searches
    // up to its nearest hit so far, a shorter interval). Empty for a mesh object: its triangles
    // have no index of their own (use closestHit()).
    std::optional<SceneHit> hitOnFace(const Ray& ray, int object, int startObject = -1,
                                      double tMax = kInfinity) const;
    // Whether commit() proved the medium sealed (see the top of this file).
    bool sealed(int medium) const {
        return medium >= 0 && medium < static_cast<int>(sealed_.size()) && sealed_[medium];
    }
    // The bodies commit() could not prove clear, each with the first mesh object found near
    // it ("L4: barrel"): their media are searched in full. For reports and tests.
    const std::vector<std::string>& bodiesNotClear() const { return bodiesNotClear_; }
    // The same by a plain loop over every face and every triangle in double precision: the
    // test oracle for closestHit().
    std::optional<SceneHit> closestHitBruteForce(const Ray& ray, double tMax = kInfinity,
                                                 int startObject = -1,
                                                 int startPrimitive = -1) const;

    // Everything as one triangle mesh in global coordinates (exact faces tessellated with
    // the given chord tolerance), with the object id of every triangle: for OBJ/PLY export.
    TriangleMesh tessellate(double chordToleranceMm, std::vector<int>* objectOfTriangle) const;

  private:
    void sealMedia();  // commit(): sealed_ and bodiesNotClear_
    std::optional<SceneHit> makeHit(int object, int primitive, double t, const Ray& ray,
                                    const Vec3& normal) const;

    std::vector<Medium> media_;
    std::vector<TriangleMesh> meshes_;
    std::vector<SceneObject> objects_;
    std::vector<int> exactObjects_;  // ids of objects with FaceGeometry
    std::vector<int> exactEntryOf_;  // [object]: its entry in embree_'s exact faces, or -1
    std::vector<ExactBody> bodies_;
    std::vector<unsigned char> sealed_;               // per medium, set by commit()
    std::vector<std::string> bodiesNotClear_;         // "L4: barrel", set by commit()
    // Per mesh triangle, all that refining an Embree candidate in double reads, on one cache
    // line: its first vertex, its normal unnormalised (the cross product of its edges from
    // that vertex) and the object it belongs to. Built by commit(); a candidate costs one
    // memory access instead of its index triple and then three vertices.
    struct alignas(64) TriangleRecord {
        Vec3 a;
        Vec3 n;
        int object = -1;
    };
    std::vector<std::vector<TriangleRecord>> triangles_;  // [mesh][triangle]
    // Per mesh, the triangles around each triangle (sharing a vertex with it, itself left
    // out), members[first[t] .. first[t + 1]): a ray leaving a mesh is tested in double
    // against them, where float candidates are unreliable (a concave corner a few nanometres
    // away), and Embree skips them.
    struct Fans {
        std::vector<uint32_t> first;
        std::vector<uint32_t> members;
    };
    std::vector<Fans> fans_;
    std::unique_ptr<EmbreeScene> embree_;  // the exact faces' index and the meshes' BVH
    bool committed_ = false;
};

}  // namespace veil
