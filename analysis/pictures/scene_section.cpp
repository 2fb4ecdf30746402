#include "analysis/pictures/scene_section.h"

#include <cmath>
#include <map>
#include <set>

#include "geometry/scene.h"

namespace veil {

namespace {

// A vertex is on the + side when x >= 0: a consistent rule, so vertices exactly on the
// plane never create dangling pieces.
bool positive(const Vec3& v) { return v.x >= 0.0; }

// Chains pieces (polylines) whose end points coincide within `tol` into longer polylines.
std::vector<std::vector<Vec2>> chain(std::vector<std::vector<Vec2>> pieces, double tol,
                                     std::vector<bool>* closedOut) {
    std::vector<std::vector<Vec2>> out;
    std::vector<bool> used(pieces.size(), false);
    auto near = [&](const Vec2& a, const Vec2& b) { return glm::length(a - b) <= tol; };
    for (size_t i = 0; i < pieces.size(); ++i) {
        if (used[i] || pieces[i].size() < 2) continue;
        used[i] = true;
        std::vector<Vec2> line = pieces[i];
        bool grew = true;
        while (grew && !near(line.front(), line.back())) {
            grew = false;
            for (size_t j = 0; j < pieces.size(); ++j) {
                if (used[j] || pieces[j].size() < 2) continue;
                const auto& p = pieces[j];
                if (near(line.back(), p.front())) {
                    line.insert(line.end(), p.begin() + 1, p.end());
                } else if (near(line.back(), p.back())) {
                    line.insert(line.end(), p.rbegin() + 1, p.rend());
                } else if (near(line.front(), p.back())) {
                    line.insert(line.begin(), p.begin(), p.end() - 1);
                } else if (near(line.front(), p.front())) {
                    line.insert(line.begin(), p.rbegin(), p.rend() - 1);
                } else {
                    continue;
                }
                used[j] = true;
                grew = true;
            }
        }
        const bool closed = line.size() > 2 && near(line.front(), line.back());
        if (closed) line.back() = line.front();
        out.push_back(std::move(line));
        if (closedOut) closedOut->push_back(closed);
    }
    return out;
}

}  // namespace

std::vector<std::vector<Vec2>> sliceMeshX0(const TriangleMesh& mesh, size_t firstTriangle,
                                           size_t triangleCount, std::vector<bool>* closed) {
    const size_t end = triangleCount == 0 ? mesh.triangles.size() : firstTriangle + triangleCount;
    std::map<std::pair<uint32_t, uint32_t>, Vec2> crossing;  // per mesh edge
    auto edgePoint = [&](uint32_t a, uint32_t b) {
        if (a > b) std::swap(a, b);
        const auto key = std::make_pair(a, b);
        auto it = crossing.find(key);
        if (it != crossing.end()) return it->second;
        const Vec3& p = mesh.vertices[a];
        const Vec3& q = mesh.vertices[b];
        const double s = p.x / (p.x - q.x);
        const Vec3 x = p + s * (q - p);
        const Vec2 zy(x.z, x.y);
        crossing.emplace(key, zy);
        return zy;
    };
    std::vector<std::vector<Vec2>> pieces;
    for (size_t t = firstTriangle; t < end; ++t) {
        const auto& tri = mesh.triangles[t];
        std::vector<Vec2> pts;
        for (int e = 0; e < 3; ++e) {
            const uint32_t a = tri[e], b = tri[(e + 1) % 3];
            if (positive(mesh.vertices[a]) != positive(mesh.vertices[b]))
                pts.push_back(edgePoint(a, b));
        }
        if (pts.size() == 2) pieces.push_back(pts);
    }
    return chain(std::move(pieces), 0.0, closed);
}

std::vector<SectionPath> sceneSection(const Scene& scene, double chordToleranceMm) {
    std::vector<SectionPath> out;
    // Exact faces, grouped by lens element: a face belongs to its own part and, for a
    // cemented face, to the element its alias names.
    std::map<std::string, std::vector<std::vector<Vec2>>> byPart;
    std::map<std::string, ObjectKind> kindOfPart;
    double scale = 1.0;
    const Bounds3 b = scene.bounds();
    if (!b.empty()) scale = std::max(1.0, glm::length(b.hi - b.lo));
    for (const SceneObject& o : scene.objects()) {
        if (const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry)) {
            std::set<std::string> parts{o.part.empty() ? o.name : o.part};
            for (const std::string& a : o.aliases) {
                const auto dot = a.find('.');
                if (dot != std::string::npos) parts.insert(a.substr(0, dot));
            }
            for (const auto& piece : sectionOfFace(*f, chordToleranceMm)) {
                std::vector<Vec2> global;
                for (const Vec2& yz : piece) {
                    const Vec3 g = o.frame.toGlobalPoint(Vec3(0.0, yz.x, yz.y));
                    global.emplace_back(g.z, g.y);
                }
                for (const std::string& part : parts) {
                    byPart[part].push_back(global);
                    if (!kindOfPart.count(part) || o.kind == ObjectKind::LensEdge)
                        kindOfPart[part] = o.kind;
                }
            }
            continue;
        }
    }
    // Meshes are sliced whole (a part split into named ranges, stop and stop.edge, closes
    // only as a whole) and drawn as the part of the first object that uses them.
    std::set<int> slicedMeshes;
    for (const SceneObject& o : scene.objects()) {
        const MeshRef* r = std::get_if<MeshRef>(&o.geometry);
        if (!r || !slicedMeshes.insert(r->mesh).second) continue;
        std::vector<bool> closed;
        const auto lines = sliceMeshX0(scene.meshes()[r->mesh], 0, 0, &closed);
        const std::string part = o.part.empty() ? o.name : o.part;
        for (size_t i = 0; i < lines.size(); ++i)
            out.push_back({part, o.kind, lines[i], closed[i]});
    }
    for (auto& [part, pieces] : byPart) {
        std::vector<bool> closed;
        const auto lines = chain(pieces, 1e-9 * scale, &closed);
        for (size_t i = 0; i < lines.size(); ++i)
            out.push_back({part, kindOfPart[part], lines[i], closed[i]});
    }
    return out;
}

}  // namespace veil
