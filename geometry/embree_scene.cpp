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
// needed), and the double-precision ray and nearest exact hit that the user-geometry callback
// reads and updates.
struct QueryContext {
    RTCIntersectContext context;  // first member: Embree hands this pointer to the callbacks
    int count;
    unsigned geom[EmbreeScene::kMaxSkips];
    unsigned prim[EmbreeScene::kMaxSkips];
    const Ray* ray;  // double, as the caller gave it (not moved)
    int startObject;
    double shift;  // how far the float ray's origin was moved along the ray (query())
    ExactCandidate* exact;
    // Faces already intersected in this query: a face is several BVH primitives (pieces,
    // facePieceBounds()) and its double intersection is done once. A ring of the last
    // kTested faces; a face pushed out of it is only intersected again, never missed.
    static constexpr int kTested = 8;
    int tested[kTested];
    int testedCount;
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

struct ExactFaceData {
    const std::vector<ExactFaceEntry>* faces;
    const std::vector<Bounds3>* bounds;  // [piece], global, padded
    const std::vector<int>* entryOfPiece;
};

void exactBounds(const RTCBoundsFunctionArguments* args) {
    const auto* data = static_cast<const ExactFaceData*>(args->geometryUserPtr);
    const Bounds3& b = (*data->bounds)[args->primID];
    // Round outward: the float box must contain the double one.
    constexpr float kInf = std::numeric_limits<float>::infinity();
    RTCBounds* o = args->bounds_o;
    o->lower_x = std::nextafter(static_cast<float>(b.lo.x), -kInf);
    o->lower_y = std::nextafter(static_cast<float>(b.lo.y), -kInf);
    o->lower_z = std::nextafter(static_cast<float>(b.lo.z), -kInf);
    o->upper_x = std::nextafter(static_cast<float>(b.hi.x), kInf);
    o->upper_y = std::nextafter(static_cast<float>(b.hi.y), kInf);
    o->upper_z = std::nextafter(static_cast<float>(b.hi.z), kInf);
}

// The user-geometry intersection: the face in double on the caller's ray, the nearest exact
// hit kept in the context; Embree gets a float t rounded up so it culls only what lies
// certainly behind (triangles at a near tie still reach Scene's double comparison).
void exactIntersect(const RTCIntersectFunctionNArguments* args) {
    if (args->N != 1 || args->valid[0] == 0) return;  // rtcIntersect1 only
    const auto* data = static_cast<const ExactFaceData*>(args->geometryUserPtr);
    auto* ctx = reinterpret_cast<QueryContext*>(args->context);
    const int entry = (*data->entryOfPiece)[args->primID];
    const int n = std::min(ctx->testedCount, QueryContext::kTested);
    for (int i = 0; i < n; ++i)
        if (ctx->tested[i] == entry) return;
    ctx->tested[ctx->testedCount++ % QueryContext::kTested] = entry;
    const ExactFaceEntry& e = (*data->faces)[entry];
    ExactCandidate& best = *ctx->exact;
    const auto hit = intersectFace(e.face, e.frame.toLocal(*ctx->ray), 0.0, best.t,
                                   e.object == ctx->startObject);
    if (!hit) return;
    const bool nearer = hit->t < best.t || best.entry < 0 ||
                        (hit->t == best.t && e.object < (*data->faces)[best.entry].object);
    if (!nearer) return;
    best.entry = entry;
    best.t = hit->t;
    best.localNormal = hit->normal;
    auto* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
    // Embree's t is relative to the (possibly moved) float origin.
    const float tf = EmbreeScene::floatBeyond(hit->t, ctx->shift);
    if (tf < rh->ray.tfar) {
        rh->ray.tfar = std::max(tf, rh->ray.tnear);
        rh->hit.geomID = args->geomID;
        rh->hit.primID = args->primID;
        rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
}

[[noreturn]] void fail(RTCDevice device, const char* what) {
    const RTCError e = rtcGetDeviceError(device);
    throw std::runtime_error(std::string("Embree: ") + what + " failed (error " +
                             std::to_string(static_cast<int>(e)) + ")");
}

}  // namespace

EmbreeScene::EmbreeScene(const std::vector<TriangleMesh>& meshes) { build(meshes); }

EmbreeScene::EmbreeScene(const std::vector<TriangleMesh>& meshes,
                         std::vector<ExactFaceEntry> exactFaces)
    : exactFaces_(std::move(exactFaces)) {
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

    // The scene's extent sets the padding of the exact faces' boxes and the distance beyond
    // which a ray's origin is moved onto the scene before the float traversal.
    Bounds3 all;
    for (const TriangleMesh& m : meshes) all.extend(m.bounds());
    for (const ExactFaceEntry& e : exactFaces_)
        all.extend(transformBounds(e.frame, faceBounds(e.face)));
    double extent = 0.0;
    if (!all.empty())
        for (int a = 0; a < 3; ++a)
            extent = std::max({extent, std::abs(all.lo[a]), std::abs(all.hi[a])});
    const double pad = kBoundsPadRelative * extent + 1e-4;
    exactBounds_.clear();
    entryOfPiece_.clear();
    for (size_t i = 0; i < exactFaces_.size(); ++i) {
        for (const Bounds3& piece : facePieceBounds(exactFaces_[i].face)) {
            Bounds3 b = transformBounds(exactFaces_[i].frame, piece);
            b.lo -= Vec3(pad);
            b.hi += Vec3(pad);
            exactBounds_.push_back(b);
            entryOfPiece_.push_back(static_cast<int>(i));
        }
    }
    sceneBox_ = all;
    if (!all.empty()) {
        sceneBox_.lo -= Vec3(2.0 * pad);
        sceneBox_.hi += Vec3(2.0 * pad);
    }
    farDistance_ = 4.0 * extent + 1.0;

    if (!exactFaces_.empty()) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
        rtcSetGeometryUserPrimitiveCount(g, static_cast<unsigned>(exactBounds_.size()));
        // The callbacks' data lives in the geometry's user pointer; it points at members of
        // this object, which is neither copied nor moved (held by unique_ptr in Scene).
        auto* data = new ExactFaceData{&exactFaces_, &exactBounds_, &entryOfPiece_};
        rtcSetGeometryUserData(g, data);
        rtcSetGeometryBoundsFunction(g, exactBounds, data);
        rtcSetGeometryIntersectFunction(g, exactIntersect);
        rtcCommitGeometry(g);
        RTCScene faces = rtcNewScene(device);
        if (!faces) fail(device, "rtcNewScene");
        faceScene_ = faces;
        rtcSetSceneFlags(faces, RTC_SCENE_FLAG_ROBUST);
        rtcSetSceneBuildQuality(faces, RTC_BUILD_QUALITY_HIGH);
        rtcAttachGeometryByID(faces, g, 0);
        rtcReleaseGeometry(g);
        userData_ = data;
        rtcCommitScene(faces);
    }
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) fail(device, "rtcCommitScene");
}

EmbreeScene::~EmbreeScene() {
    if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
    if (faceScene_) rtcReleaseScene(static_cast<RTCScene>(faceScene_));
    if (device_) rtcReleaseDevice(static_cast<RTCDevice>(device_));
    delete static_cast<ExactFaceData*>(userData_);
}

std::optional<MeshCandidate> EmbreeScene::query(const Ray& ray, float tNear, float tFar,
                                                int startObject, const Skip* skips, int skipCount,
                                                ExactCandidate& exact) const {
    if (empty()) return std::nullopt;
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
    ctx.ray = &ray;
    ctx.testedCount = 0;
    ctx.startObject = startObject;
    ctx.exact = &exact;

    // A far origin (a point source metres away) is moved to where the ray enters the scene's
    // box, so float rounding of the origin stays within the boxes' padding. `shift` is the
    // double distance moved; Embree's t values are relative to the moved origin.
    double shift = 0.0;
    Vec3 origin = ray.origin;
    const Vec3 offset = glm::max(sceneBox_.lo - ray.origin, ray.origin - sceneBox_.hi);
    if (std::max({offset.x, offset.y, offset.z}) > farDistance_) {
        double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
        if (!sceneBox_.clip(ray, t0, t1)) return std::nullopt;  // misses everything
        shift = t0;
        origin = ray.origin + shift * ray.direction;
    }
    ctx.shift = shift;

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
    // Exact faces first, in their own BVH (on the tracer's rays 10 % faster than one BVH mixing
    // them with the triangles, docs/performance.md). A repeated query (tNear > 0, beyond a
    // refused triangle) has seen every face already.
    if (faceScene_ && tNear == 0.0f) {
        RTCRayHit rf = floatRay(tFarMoved);
        rtcIntersect1(static_cast<RTCScene>(faceScene_), &ctx.context, &rf);
    }
    if (meshCount_ == 0) return std::nullopt;
    // Then the triangles, no farther than the nearest exact face (rounded up: a triangle at a
    // near tie still reaches Scene's double comparison).
    if (exact.entry >= 0) tFarMoved = std::min(tFarMoved, floatBeyond(exact.t, shift));
    RTCRayHit rh = floatRay(tFarMoved);
    rtcIntersect1(static_cast<RTCScene>(scene_), &ctx.context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    return MeshCandidate{static_cast<int>(rh.hit.geomID), static_cast<int>(rh.hit.primID),
                         static_cast<float>(rh.ray.tfar + shift)};
}

}  // namespace veil
