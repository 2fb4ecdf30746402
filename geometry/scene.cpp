#include "geometry/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/embree_scene.h"

namespace veil {

std::string_view toString(ObjectKind k) {
    switch (k) {
        case ObjectKind::LensFace:
            return "lens face";
        case ObjectKind::MirrorFace:
            return "mirror";
        case ObjectKind::LensEdge:
            return "lens edge";
        case ObjectKind::LensFlat:
            return "lens flat";
        case ObjectKind::Stop:
            return "stop";
        case ObjectKind::Mechanics:
            return "mechanics";
        case ObjectKind::ImportedMesh:
            return "imported mesh";
        case ObjectKind::Detector:
            return "detector";
        case ObjectKind::Dummy:
            return "dummy";
    }
    return "?";
}

std::ostream& operator<<(std::ostream& os, ObjectKind k) { return os << toString(k); }

std::ostream& operator<<(std::ostream& os, const SceneObject& o) {
    os << "SceneObject{#" << o.id << " " << o.name << " (" << o.kind << ")";
    if (!o.property.empty()) os << " property " << o.property;
    os << " media " << o.mediumBack << "|" << o.mediumFront;
    if (std::holds_alternative<MeshRef>(o.geometry)) {
        const MeshRef& m = std::get<MeshRef>(o.geometry);
        os << " mesh " << m.mesh << " [" << m.firstTriangle << ", +" << m.triangleCount << ")";
    } else {
        os << " " << std::get<FaceGeometry>(o.geometry);
    }
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const SceneHit& h) {
    return os << "SceneHit{object " << h.object << " primitive " << h.primitive << " t=" << h.t
              << " at " << h.point << " normal " << h.normal << (h.fromFront ? " front" : " back")
              << " media " << h.mediumFrom << "->" << h.mediumTo << "}";
}

// Scene Public Methods

Scene::Scene() { media_.push_back({"air", Material::air()}); }
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

int Scene::addMedium(Medium m) {
    for (size_t i = 0; i < media_.size(); ++i)
        if (media_[i].material == m.material) return static_cast<int>(i);
    media_.push_back(std::move(m));
    return static_cast<int>(media_.size()) - 1;
}

int Scene::addMesh(TriangleMesh mesh) {
    meshes_.push_back(std::move(mesh));
    committed_ = false;
    return static_cast<int>(meshes_.size()) - 1;
}

const SceneObject* Scene::find(const std::string& name) const {
    for (const SceneObject& o : objects_) {
        if (o.name == name) return &o;
        for (const std::string& a : o.aliases)
            if (a == name) return &o;
    }
    return nullptr;
}

int Scene::addObject(SceneObject o) {
    auto clash = [&](const std::string& n) {
        if (const SceneObject* other = find(n))
            throw ModelError(o.name, "name '" + n + "' is already used by " + other->name);
    };
    if (o.name.empty()) throw ModelError("scene", "an object needs a name");
    clash(o.name);
    for (const std::string& a : o.aliases) clash(a);
    if (o.mediumFront < 0 || o.mediumFront >= static_cast<int>(media_.size()) || o.mediumBack < 0 ||
        o.mediumBack >= static_cast<int>(media_.size()))
        throw ModelError(o.name, "unknown medium index");
    if (const MeshRef* m = std::get_if<MeshRef>(&o.geometry)) {
        if (m->mesh < 0 || m->mesh >= static_cast<int>(meshes_.size()))
            throw ModelError(o.name, "unknown mesh index");
        const size_t n = meshes_[m->mesh].triangles.size();
        if (m->firstTriangle > n || m->firstTriangle + m->triangleCount > n)
            throw ModelError(o.name, "triangle range outside its mesh");
    }
    o.id = static_cast<int>(objects_.size());
    objects_.push_back(std::move(o));
    committed_ = false;
    return objects_.back().id;
}

void Scene::addExactBody(ExactBody body) {
    if (body.medium <= 0 || body.medium >= static_cast<int>(media_.size()))
        throw ModelError(body.part, "a body needs a medium other than air");
    if (!(body.radiusMm > 0.0) || !body.zRange)
        throw ModelError(body.part, "a body needs a radius and a z enclosure");
    bodies_.push_back(std::move(body));
    committed_ = false;
}

namespace {

// Whether the triangle (a, b, c), in the body's local frame, stays at least `margin` away
// from the body: in the (r, z) half-plane the triangle lies within its box (r from its exact
// distance to the axis to its farthest vertex, z between its vertices'), and the body at
// those radii within zRange().
bool triangleClearOf(const ExactBody& body, const Vec3& a, const Vec3& b, const Vec3& c,
                     double margin) {
    const double zMin = std::min({a.z, b.z, c.z}), zMax = std::max({a.z, b.z, c.z});
    const double rMax =
        std::sqrt(std::max({a.x * a.x + a.y * a.y, b.x * b.x + b.y * b.y, c.x * c.x + c.y * c.y}));
    // The distance from the axis: 0 when the triangle's projection on the xy plane holds the
    // origin (a degenerate projection counts as holding it when collinear: conservative),
    // else the nearest of its three edges.
    auto cross = [](const Vec3& p, const Vec3& q) { return p.x * q.y - p.y * q.x; };
    const double d1 = cross(a, b), d2 = cross(b, c), d3 = cross(c, a);
    double rMin = 0.0;
    if (!((d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0) || (d1 <= 0.0 && d2 <= 0.0 && d3 <= 0.0))) {
        auto segment = [](const Vec3& p, const Vec3& q) {
            const double ex = q.x - p.x, ey = q.y - p.y;
            const double len = ex * ex + ey * ey;
            const double s = len > 0.0 ? std::clamp(-(p.x * ex + p.y * ey) / len, 0.0, 1.0) : 0.0;
            return std::hypot(p.x + s * ex, p.y + s * ey);
        };
        rMin = std::min({segment(a, b), segment(b, c), segment(c, a)});
    }
    if (rMin >= body.radiusMm + margin) return true;
    double lo = 0.0, hi = 0.0;
    body.zRange(std::max(0.0, rMin - margin), std::min(body.radiusMm, rMax + margin), lo, hi);
    return zMax <= lo - margin || zMin >= hi + margin;
}

}  // namespace

void Scene::commit() {
    exactObjects_.clear();
    triangles_.assign(meshes_.size(), {});
    for (size_t m = 0; m < meshes_.size(); ++m) {
        const TriangleMesh& mesh = meshes_[m];
        triangles_[m].resize(mesh.triangles.size());
        for (size_t t = 0; t < mesh.triangles.size(); ++t) {
            const auto& tri = mesh.triangles[t];
            TriangleRecord& r = triangles_[m][t];
            r.a = mesh.vertices[tri[0]];
            r.n = glm::cross(mesh.vertices[tri[1]] - r.a, mesh.vertices[tri[2]] - r.a);
        }
    }
    exactEntryOf_.assign(objects_.size(), -1);
    for (const SceneObject& o : objects_) {
        if (std::holds_alternative<FaceGeometry>(o.geometry)) {
            exactEntryOf_[static_cast<size_t>(o.id)] = static_cast<int>(exactObjects_.size());
            exactObjects_.push_back(o.id);
        } else {
            const MeshRef& r = std::get<MeshRef>(o.geometry);
            const uint32_t n = static_cast<uint32_t>(meshes_[r.mesh].triangles.size());
            const uint32_t end = r.triangleCount == 0 ? n : r.firstTriangle + r.triangleCount;
            for (uint32_t t = r.firstTriangle; t < end; ++t) {
                int& owner = triangles_[r.mesh][t].object;
                if (owner >= 0)
                    throw ModelError(o.name, "shares triangles with " + objects_[owner].name);
                owner = o.id;
            }
        }
    }
    // Each triangle's fan: the other triangles that share a vertex with it, each once, in the
    // order its vertices and their triangles come (the order closestHit() breaks ties in).
    fans_.assign(meshes_.size(), {});
    for (size_t m = 0; m < meshes_.size(); ++m) {
        const TriangleMesh& mesh = meshes_[m];
        std::vector<std::vector<uint32_t>> ofVertex(mesh.vertices.size());
        for (size_t t = 0; t < mesh.triangles.size(); ++t)
            for (uint32_t v : mesh.triangles[t]) ofVertex[v].push_back(static_cast<uint32_t>(t));
        Fans& fan = fans_[m];
        fan.first.reserve(mesh.triangles.size() + 1);
        for (size_t t = 0; t < mesh.triangles.size(); ++t) {
            fan.first.push_back(static_cast<uint32_t>(fan.members.size()));
            const size_t begin = fan.members.size();
            for (uint32_t v : mesh.triangles[t])
                for (uint32_t n : ofVertex[v])
                    if (n != t && std::find(fan.members.begin() + begin, fan.members.end(), n) ==
                                      fan.members.end())
                        fan.members.push_back(n);
        }
        fan.first.push_back(static_cast<uint32_t>(fan.members.size()));
    }
    // Triangles no object claims would be hit without a name: refuse such a scene.
    for (size_t m = 0; m < meshes_.size(); ++m)
        for (size_t t = 0; t < triangles_[m].size(); ++t)
            if (triangles_[m][t].object < 0)
                throw ModelError("mesh " + std::to_string(m),
                                 "triangle " + std::to_string(t) + " belongs to no object");
    std::vector<ExactFaceEntry> faces;
    for (int id : exactObjects_)
        faces.push_back({id, objects_[id].frame, std::get<FaceGeometry>(objects_[id].geometry)});
    embree_ = std::make_unique<EmbreeScene>(meshes_, std::move(faces));
    sealMedia();
    committed_ = true;
}

void Scene::sealMedia() {
    sealed_.assign(media_.size(), 0);
    bodiesNotClear_.clear();
    std::vector<int> bodies(media_.size(), 0), clear(media_.size(), 0);
    for (const ExactBody& body : bodies_) {
        ++bodies[body.medium];
        // Far beyond rounding (relative 1e-9 of the body's size), far below any gap the
        // mechanics keeps (contact_gap_mm, 1 um by default).
        double lo = 0.0, hi = 0.0;
        body.zRange(0.0, body.radiusMm, lo, hi);
        const double margin = 1e-9 * (1.0 + std::max({body.radiusMm, std::abs(lo), std::abs(hi),
                                                      glm::length(body.frame.translation)}));
        const SceneObject* near = nullptr;
        for (size_t m = 0; m < meshes_.size() && !near; ++m) {
            const TriangleMesh& mesh = meshes_[m];
            for (size_t t = 0; t < mesh.triangles.size(); ++t) {
                const auto& tri = mesh.triangles[t];
                const Vec3 a = body.frame.toLocalPoint(mesh.vertices[tri[0]]);
                const Vec3 b = body.frame.toLocalPoint(mesh.vertices[tri[1]]);
                const Vec3 c = body.frame.toLocalPoint(mesh.vertices[tri[2]]);
                if (!triangleClearOf(body, a, b, c, margin)) {
                    near = &objects_[triangles_[m][t].object];
                    break;
                }
            }
        }
        if (near)
            bodiesNotClear_.push_back(body.part + ": " + near->name);
        else
            ++clear[body.medium];
    }
    // Every object bordering the medium must be an exact face of a body's part.
    std::vector<unsigned char> bordered(media_.size(), 1);
    for (const SceneObject& o : objects_) {
        bool ofBody = false;
        if (std::holds_alternative<FaceGeometry>(o.geometry))
            for (const ExactBody& body : bodies_) ofBody = ofBody || body.part == o.part;
        if (!ofBody) bordered[o.mediumFront] = bordered[o.mediumBack] = 0;
    }
    for (size_t m = 1; m < media_.size(); ++m)
        sealed_[m] = bodies[m] > 0 && clear[m] == bodies[m] && bordered[m];
}

Bounds3 Scene::bounds() const {
    Bounds3 b;
    for (const SceneObject& o : objects_) {
        if (const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry))
            b.extend(transformBounds(o.frame, faceBounds(*f)));
    }
    for (const TriangleMesh& m : meshes_) b.extend(m.bounds());
    return b;
}

std::optional<SceneHit> Scene::makeHit(int object, int primitive, double t, const Ray& ray,
                                       const Vec3& normal) const {
    const SceneObject& o = objects_[object];
    // Written field by field into the returned optional: a SceneHit built aside and copied in
    // would be read back through wider loads than it was written with (a store-forwarding
    // stall on every query).
    std::optional<SceneHit> out;
    SceneHit& h = out.emplace();
    h.object = object;
    h.primitive = primitive;
    h.t = t;
    h.point = ray.origin + t * ray.direction;
    h.normal = normal;
    h.fromFront = glm::dot(ray.direction, normal) < 0.0;
    h.mediumFrom = h.fromFront ? o.mediumFront : o.mediumBack;
    h.mediumTo = h.fromFront ? o.mediumBack : o.mediumFront;
    return out;
}

std::optional<SceneHit> Scene::hitOnFace(const Ray& ray, int object, int startObject,
                                         double tMax) const {
    if (!committed_) throw ModelError("scene", "hitOnFace() before commit()");
    const SceneObject& o = objects_[static_cast<size_t>(object)];
    const int entry = exactEntryOf_[static_cast<size_t>(object)];
    if (entry < 0) return std::nullopt;
    FaceCrossing hit;
    if (!embree_->crossExact(entry, ray, startObject, tMax, hit)) return std::nullopt;
    const FaceGeometry& f = std::get<FaceGeometry>(o.geometry);
    const Vec3 normal = hit.hasNormal ? hit.normal : faceNormal(f, hit.point);
    return makeHit(object, 0, hit.t, ray, o.frame.toGlobalDirection(normal));
}

std::optional<SceneHit> Scene::closestHit(const Ray& ray, double tMax, int startObject,
                                          int startPrimitive, int medium) const {
    if (!committed_) throw ModelError("scene", "closestHit() before commit()");
    // The exact faces in double (geometry/face_index.h), then the triangles up to the nearest
    // one (geometry/embree_scene.h); the nearest exact face is the first candidate.
    ExactCandidate exact;
    exact.t = tMax;
    const MeshRef* startMesh = startObject >= 0 && startPrimitive >= 0
                                   ? std::get_if<MeshRef>(&objects_[startObject].geometry)
                                   : nullptr;
    if (sealed(medium) && !startMesh) {
        // Inside a lens body no triangle comes before the face the ray leaves it through.
        embree_->nearestExact(ray, startObject, exact);
        if (exact.entry < 0) return std::nullopt;
        const ExactFaceEntry& e = embree_->exactFaces()[exact.entry];
        return makeHit(e.object, 0, exact.t, ray, e.frame.toGlobalDirection(exact.localNormal));
    }
    EmbreeScene::Skip skips[EmbreeScene::kMaxSkips];
    int skipCount = 0;
    if (startMesh) {
        // The start triangle and the triangles around its vertices: Embree would see them in
        // float at t ~ 0 (a candidate to refuse and a repeated query); they are tested in
        // double below instead. A fan too large for the list is partly left to Embree, whose
        // candidates are refined and refused as needed: slower, never wrong.
        skips[skipCount++] = {startMesh->mesh, startPrimitive};
        const Fans& fan = fans_[startMesh->mesh];
        for (uint32_t i = fan.first[startPrimitive]; i < fan.first[startPrimitive + 1]; ++i) {
            if (skipCount == EmbreeScene::kMaxSkips - 4) break;  // room for refusals
            skips[skipCount++] = {startMesh->mesh, static_cast<int>(fan.members[i])};
        }
    }
    const float tFar = std::isfinite(tMax) ? EmbreeScene::floatBeyond(tMax)
                                           : std::numeric_limits<float>::infinity();
    MeshCandidate candidate;
    bool found = embree_->query(ray, 0.0f, tFar, startObject, skips, skipCount, exact, candidate);

    // The triangle candidate (float) gets its t in double from its plane. A candidate whose
    // double t is not ahead of the origin (a neighbour of the start triangle seen through
    // float rounding) is skipped and the query repeated beyond it; exact faces the first
    // query culled behind that candidate are seen by the repeat (`exact` accumulates).
    double meshT = 0.0;
    const TriangleRecord* meshTriangle = nullptr;
    while (found) {
        meshTriangle = &triangles_[candidate.mesh][candidate.triangle];
        const Vec3& n = meshTriangle->n;
        const double denom = glm::dot(ray.direction, n);
        meshT = denom != 0.0 ? glm::dot(meshTriangle->a - ray.origin, n) / denom : 0.0;
        if (meshT > 0.0) break;
        if (skipCount == EmbreeScene::kMaxSkips) {
            found = false;
            break;
        }
        skips[skipCount++] = {candidate.mesh, candidate.triangle};
        found =
            embree_->query(ray, candidate.t, tFar, startObject, skips, skipCount, exact, candidate);
    }

    // In double, in a fixed order: the nearest exact face, then the start triangle's
    // neighbours, then the triangle candidate; a later one wins only when strictly nearer.
    int bestObject = -1, bestPrimitive = 0;
    double bestT = tMax;
    Vec3 bestNormal(0.0);
    if (exact.entry >= 0) {
        const ExactFaceEntry& e = embree_->exactFaces()[exact.entry];
        bestT = exact.t;
        bestObject = e.object;
        bestNormal = e.frame.toGlobalDirection(exact.localNormal);
    }
    // A ray leaving a mesh is tested in double against the triangles around its start
    // triangle, where float candidates are unreliable (a concave corner nanometres away).
    if (startMesh) {
        const TriangleMesh& m = meshes_[startMesh->mesh];
        const Fans& fan = fans_[startMesh->mesh];
        for (uint32_t i = fan.first[startPrimitive]; i < fan.first[startPrimitive + 1]; ++i) {
            const uint32_t t = fan.members[i];
            const auto& tri = m.triangles[t];
            const auto th = intersectTriangle(m.vertices[tri[0]], m.vertices[tri[1]],
                                              m.vertices[tri[2]], ray, 0.0, bestT);
            if (th && *th < bestT) {
                bestT = *th;
                bestObject = triangles_[startMesh->mesh][t].object;
                bestPrimitive = static_cast<int>(t);
                bestNormal = m.triangleNormal(t);
            }
        }
    }
    if (found && meshT < bestT) {
        bestT = meshT;
        bestObject = meshTriangle->object;
        bestPrimitive = candidate.triangle;
        bestNormal = glm::normalize(meshTriangle->n);
    }
    if (bestObject < 0) return std::nullopt;
    return makeHit(bestObject, bestPrimitive, bestT, ray, bestNormal);
}

std::optional<SceneHit> Scene::closestHitBruteForce(const Ray& ray, double tMax, int startObject,
                                                    int startPrimitive) const {
    int bestObject = -1, bestPrimitive = 0;
    double bestT = tMax;
    Vec3 bestNormal(0.0);
    for (const SceneObject& o : objects_) {
        if (const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry)) {
            const auto hit =
                intersectFace(*f, o.frame.toLocal(ray), 0.0, bestT, o.id == startObject);
            if (hit && hit->t < bestT) {
                bestT = hit->t;
                bestObject = o.id;
                bestPrimitive = 0;
                bestNormal = o.frame.toGlobalDirection(hit->normal);
            }
            continue;
        }
        const MeshRef& r = std::get<MeshRef>(o.geometry);
        const TriangleMesh& m = meshes_[r.mesh];
        const uint32_t end = r.triangleCount == 0 ? static_cast<uint32_t>(m.triangles.size())
                                                  : r.firstTriangle + r.triangleCount;
        for (uint32_t t = r.firstTriangle; t < end; ++t) {
            if (o.id == startObject && static_cast<int>(t) == startPrimitive) continue;
            const auto& tri = m.triangles[t];
            const auto th = intersectTriangle(m.vertices[tri[0]], m.vertices[tri[1]],
                                              m.vertices[tri[2]], ray, 0.0, bestT);
            if (th && *th < bestT) {
                bestT = *th;
                bestObject = o.id;
                bestPrimitive = static_cast<int>(t);
                bestNormal = m.triangleNormal(t);
            }
        }
    }
    if (bestObject < 0) return std::nullopt;
    return makeHit(bestObject, bestPrimitive, bestT, ray, bestNormal);
}

TriangleMesh Scene::tessellate(double chordToleranceMm, std::vector<int>* objectOfTriangle) const {
    TriangleMesh out;
    if (objectOfTriangle) objectOfTriangle->clear();
    for (const SceneObject& o : objects_) {
        TriangleMesh part;
        if (const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry)) {
            part = tessellateFace(*f, chordToleranceMm);
            part.transform(o.frame);
        } else {
            const MeshRef& r = std::get<MeshRef>(o.geometry);
            const TriangleMesh& m = meshes_[r.mesh];
            const uint32_t end = r.triangleCount == 0 ? static_cast<uint32_t>(m.triangles.size())
                                                      : r.firstTriangle + r.triangleCount;
            part.vertices = m.vertices;  // unused vertices are harmless in OBJ/PLY
            part.triangles.assign(m.triangles.begin() + r.firstTriangle, m.triangles.begin() + end);
        }
        out.append(part);
        if (objectOfTriangle)
            objectOfTriangle->insert(objectOfTriangle->end(), part.triangles.size(), o.id);
    }
    return out;
}

}  // namespace veil
