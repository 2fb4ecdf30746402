#include "analysis/runs/saved_rays.h"

#include <algorithm>
#include <iomanip>
#include <mutex>
#include <sstream>
#include <vector>

#include "lensdata/errors.h"
#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/transport/interaction.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

namespace {

std::string size(double b) {
    std::ostringstream os;
    os << std::setprecision(3);
    if (b >= 1e9)
        os << b / 1e9 << " GB";
    else if (b >= 1e6)
        os << b / 1e6 << " MB";
    else
        os << b / 1e3 << " kB";
    return os.str();
}

}  // namespace

RayDatabaseEstimate estimateRayDatabase(const SceneTransport& trace,
                                        const TransportOptions& options, uint64_t raysPerSource,
                                        const PathEncoding& encoding) {
    const TransportView& ts = trace.view;
    const uint64_t sample = std::min<uint64_t>(raysPerSource, 200);
    TransportOptions o = options;
    o.recordHistories = true;
    std::mutex m;
    uint64_t bytes = 0, events = 0;
    traceNonsequential(ts, trace.images, sample, o, {}, [&](uint64_t, const PathHistory& h) {
        std::vector<uint8_t> buffer;
        encodeHistory(h, encoding, buffer);
        std::lock_guard lock(m);
        bytes += buffer.size();
        events += h.size();
    });
    RayDatabaseEstimate e;
    e.sampleRays = sample * ts.sources.size();
    e.rays = raysPerSource * ts.sources.size();
    e.bytesPerRay = static_cast<double>(bytes) / static_cast<double>(e.sampleRays);
    e.eventsPerRay = static_cast<double>(events / std::max<uint64_t>(1, e.sampleRays));
    return e;
}

std::string RayDatabaseEstimate::note(const std::string& path, const PathEncoding& encoding) const {
    std::ostringstream os;
    os << "about " << size(totalBytes()) << " for " << rays << " rays (" << size(bytesPerRay)
       << " per ray, from the first " << sampleRays << " rays"
       << (encoding.positions ? "; --events-only stores about a quarter" : ", events only")
       << ") to " << path;
    return os.str();
}

void RayDatabaseEstimate::checkFits(const std::filesystem::path& path) const {
    std::filesystem::path folder = path.parent_path();
    if (folder.empty()) folder = ".";
    while (!std::filesystem::exists(folder) && folder.has_parent_path() &&
           folder != folder.parent_path())
        folder = folder.parent_path();
    std::error_code ec;
    const std::filesystem::space_info space = std::filesystem::space(folder, ec);
    if (!ec && totalBytes() > 0.95 * static_cast<double>(space.available))
        throw ParseError({"--save-rays " + path.string(), 0, 0},
                         "the ray database would take about " + size(totalBytes()) + " (" +
                             size(bytesPerRay) + " per ray, " +
                             std::to_string(static_cast<uint64_t>(eventsPerRay)) +
                             " events per ray) and " + folder.string() + " has " +
                             size(static_cast<double>(space.available)) +
                             " free: trace fewer rays, add --events-only, or save elsewhere");
}

RayDatabaseInfo rayDatabaseInfo(const PreparedScene& scene, const std::string& sceneName,
                                const PathEncoding& encoding, uint64_t seed) {
    const SceneGeometry& setup = scene.geometry();
    const TransportView& ts = scene.transport().view;
    RayDatabaseInfo info = describeScene(setup.scene, sceneName);
    info.encoding = encoding;
    for (const DetectorGeometry& d : setup.detectors) {
        RayDatabaseObject& obj = info.objects[d.object];
        if (d.name != obj.name) obj.aliases.push_back(d.name);
    }
    info.seed = seed;
    info.fluxUnit = ts.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
    for (const Source& src : ts.sources) info.sources.push_back(src.name());
    return info;
}

}  // namespace veil
