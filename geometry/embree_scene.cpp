#include "geometry/embree_scene.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace veil {

namespace {

// The intersection context of one query: the triangles to skip (the one a ray starts on,
// candidates already refused; the context filter rejects them, so no epsilon offset is
// needed).
struct QueryContext {
    RTCIntersectContext context;  // first member: Embree hands this pointer to the filter
    int count;
    unsigned geom[EmbreeScene::kMaxSkips];
    unsigned prim[EmbreeScene::kMaxSkips];
};

void skipFilter(const RTCFilterFunctionNArguments* args) {
    const auto* ctx = reinterpret_cast<const QueryContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        const unsigned geom = RTCHitN_geomID(args->hit, args->N, i);
        const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
        for (int k = 0; k < ctx->count; ++k)
            if (geom == ctx->geom[k] && prim == ctx->prim[k]) args->valid[i] = 0;
    }
}

// Origins farther than this (relative to the scene's extent, plus 1e-4 mm) outside the
// meshes' box are moved onto it before the float traversal, so the float ray stays within
// rounding of the double one where the triangles are.
constexpr double kBoxPadRelative = 1e-5;

[[noreturn]] void fail(RTCDevice device, const char* what) {
    const RTCError e = rtcGetDeviceError(device);
    throw std::runtime_error(std::string("Embree: ") + what + " failed (error " +
                             std::to_string(static_cast<int>(e)) + ")");
}

}  // namespace

EmbreeScene::EmbreeScene(const std::vector<TriangleMesh>& meshes) { build(meshes); }

EmbreeScene::EmbreeScene(const std::vector<TriangleMesh>& meshes,
                         std::vector<ExactFaceEntry> exactFaces)
    : faces_(std::move(exactFaces)) {
    build(meshes);
}

void EmbreeScene::build(const std::vector<TriangleMesh>& meshes) {
    RTCDevice device = rtcNewDevice(nullptr);
    if (!device) throw std::runtime_error("Embree: cannot create a device");
    device_ = device;
    RTCScene scene = rtcNewScene(device);
    if (!scene) fail(device, "rtcNewScene");
    scene_ = scene;
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    for (const TriangleMesh& m : meshes) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
            g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m.vertices.size()));
        auto* idx = static_cast<unsigned*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                    3 * sizeof(unsigned), m.triangles.size()));
        if (!v || !idx) fail(device, "rtcSetNewGeometryBuffer");
        for (size_t i = 0; i < m.vertices.size(); ++i) {
            v[3 * i + 0] = static_cast<float>(m.vertices[i].x);
            v[3 * i + 1] = static_cast<float>(m.vertices[i].y);
            v[3 * i + 2] = static_cast<float>(m.vertices[i].z);
        }
        for (size_t i = 0; i < m.triangles.size(); ++i)
            for (int k = 0; k < 3; ++k) idx[3 * i + k] = m.triangles[i][k];
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(scene, g, static_cast<unsigned>(meshCount_));
        rtcReleaseGeometry(g);
        ++meshCount_;
    }

    // Far origins are moved onto the meshes' box before the float traversal (query()).
    Bounds3 all;
    for (const TriangleMesh& m : meshes) all.extend(m.bounds());
    double extent = 0.0;
    if (!all.empty())
        for (int a = 0; a < 3; ++a)
            extent = std::max({extent, std::abs(all.lo[a]), std::abs(all.hi[a])});
    const double pad = kBoxPadRelative * extent + 1e-4;
    sceneBox_ = all;
    if (!all.empty()) {
        sceneBox_.lo -= Vec3(2.0 * pad);
        sceneBox_.hi += Vec3(2.0 * pad);
    }
    farDistance_ = 4.0 * extent + 1.0;
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) fail(device, "rtcCommitScene");
}

EmbreeScene::~EmbreeScene() {
    if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
    if (device_) rtcReleaseDevice(static_cast<RTCDevice>(device_));
}

bool EmbreeScene::query(const Ray& ray, float tNear, float tFar, int startObject, const Skip* skips,
                        int skipCount, ExactCandidate& exact, MeshCandidate& mesh) const {
    if (empty()) return false;
    QueryContext ctx;
    rtcInitIntersectContext(&ctx.context);
    ctx.count = 0;
    for (int k = 0; k < skipCount && k < kMaxSkips; ++k) {
        if (skips[k].mesh < 0 || skips[k].triangle < 0) continue;
        ctx.geom[ctx.count] = static_cast<unsigned>(skips[k].mesh);
        ctx.prim[ctx.count] = static_cast<unsigned>(skips[k].triangle);
        ++ctx.count;
    }
    if (ctx.count > 0) ctx.context.filter = skipFilter;
    // Exact faces first, in double. A repeated query (tNear > 0, beyond a refused
    // triangle) has seen every face already.
    if (tNear == 0.0f) faces_.nearest(ray, startObject, exact);
    if (meshCount_ == 0) return false;

    // A far origin (a point source metres away) is moved to where the ray enters the scene's
    // box, so float rounding of the origin stays small where the triangles are. `shift` is the
    // double distance moved; Embree's t values are relative to the moved origin.
    double shift = 0.0;
    Vec3 origin = ray.origin;
    const Vec3 offset = glm::max(sceneBox_.lo - ray.origin, ray.origin - sceneBox_.hi);
    if (std::max({offset.x, offset.y, offset.z}) > farDistance_) {
        double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
        if (!sceneBox_.clip(ray, t0, t1)) return false;  // misses every triangle
        shift = t0;
        origin = ray.origin + shift * ray.direction;
    }

    auto floatRay = [&](float tFarMoved) {
        RTCRayHit rh{};
        rh.ray.org_x = static_cast<float>(origin.x);
        rh.ray.org_y = static_cast<float>(origin.y);
        rh.ray.org_z = static_cast<float>(origin.z);
        rh.ray.dir_x = static_cast<float>(ray.direction.x);
        rh.ray.dir_y = static_cast<float>(ray.direction.y);
        rh.ray.dir_z = static_cast<float>(ray.direction.z);
        rh.ray.tnear = std::max(0.0f, static_cast<float>(tNear - shift));
        rh.ray.tfar = tFarMoved;
        rh.ray.mask = std::numeric_limits<unsigned>::max();
        rh.ray.flags = 0;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        return rh;
    };
    float tFarMoved = static_cast<float>(static_cast<double>(tFar) - shift);
    // The triangles, no farther than the nearest exact face (rounded up: a triangle at a
    // near tie still reaches Scene's double comparison).
    if (exact.entry >= 0) tFarMoved = std::min(tFarMoved, floatBeyond(exact.t, shift));
    RTCRayHit rh = floatRay(tFarMoved);
    rtcIntersect1(static_cast<RTCScene>(scene_), &ctx.context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    mesh.mesh = static_cast<int>(rh.hit.geomID);
    mesh.triangle = static_cast<int>(rh.hit.primID);
    mesh.t = static_cast<float>(rh.ray.tfar + shift);
    return true;
}

}  // namespace veil
