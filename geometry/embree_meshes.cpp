#include "geometry/embree_meshes.h"

#include <embree3/rtcore.h>

#include <limits>
#include <stdexcept>
#include <string>

namespace veil {

namespace {

// The intersection context carries the triangle to skip (the one a ray starts on); the
// context filter rejects it, so no epsilon offset is needed.
struct SkipContext {
    RTCIntersectContext context;  // first member: Embree hands this pointer to the filter
    int count;
    unsigned geom[EmbreeMeshes::kMaxSkips];
    unsigned prim[EmbreeMeshes::kMaxSkips];
};

void skipFilter(const RTCFilterFunctionNArguments* args) {
    const auto* ctx = reinterpret_cast<const SkipContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        const unsigned geom = RTCHitN_geomID(args->hit, args->N, i);
        const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
        for (int k = 0; k < ctx->count; ++k)
            if (geom == ctx->geom[k] && prim == ctx->prim[k]) args->valid[i] = 0;
    }
}

[[noreturn]] void fail(RTCDevice device, const char* what) {
    const RTCError e = rtcGetDeviceError(device);
    throw std::runtime_error(std::string("Embree: ") + what + " failed (error " +
                             std::to_string(static_cast<int>(e)) + ")");
}

}  // namespace

EmbreeMeshes::EmbreeMeshes(const std::vector<TriangleMesh>& meshes) {
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
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) fail(device, "rtcCommitScene");
}

EmbreeMeshes::~EmbreeMeshes() {
    if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
    if (device_) rtcReleaseDevice(static_cast<RTCDevice>(device_));
}

std::optional<EmbreeHit> EmbreeMeshes::intersect(const Ray& ray, float tNear, float tFar,
                                                 const Skip* skips, int skipCount) const {
    if (meshCount_ == 0) return std::nullopt;
    SkipContext ctx;
    rtcInitIntersectContext(&ctx.context);
    ctx.count = 0;
    for (int k = 0; k < skipCount && k < kMaxSkips; ++k) {
        if (skips[k].mesh < 0 || skips[k].triangle < 0) continue;
        ctx.geom[ctx.count] = static_cast<unsigned>(skips[k].mesh);
        ctx.prim[ctx.count] = static_cast<unsigned>(skips[k].triangle);
        ++ctx.count;
    }
    if (ctx.count > 0) ctx.context.filter = skipFilter;

    RTCRayHit rh{};
    rh.ray.org_x = static_cast<float>(ray.origin.x);
    rh.ray.org_y = static_cast<float>(ray.origin.y);
    rh.ray.org_z = static_cast<float>(ray.origin.z);
    rh.ray.dir_x = static_cast<float>(ray.direction.x);
    rh.ray.dir_y = static_cast<float>(ray.direction.y);
    rh.ray.dir_z = static_cast<float>(ray.direction.z);
    rh.ray.tnear = tNear;
    rh.ray.tfar = tFar;
    rh.ray.mask = std::numeric_limits<unsigned>::max();
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(static_cast<RTCScene>(scene_), &ctx.context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    return EmbreeHit{static_cast<int>(rh.hit.geomID), static_cast<int>(rh.hit.primID), rh.ray.tfar};
}

}  // namespace veil
