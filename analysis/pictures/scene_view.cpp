#include "analysis/pictures/scene_view.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "analysis/reports/image_output.h"
#include "geometry/scene.h"
#include "lensdata/input_file.h"
#include "lensdata/output_file.h"

namespace veil {

// The viewer page, analysis/pictures/scene_view.html, compiled in (scene_view_template.cpp is
// generated from it by analysis/CMakeLists.txt with tools/embed_file.cmake).
namespace detail {
extern const char kSceneViewTemplate[];
extern const unsigned long kSceneViewTemplateSize;
}  // namespace detail

namespace {

std::string hexColour(const Color& c) {
    auto byte = [](double v) {
        return static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
    };
    std::ostringstream os;
    os << '#' << std::hex << std::setfill('0') << std::setw(2) << byte(c.r) << std::setw(2)
       << byte(c.g) << std::setw(2) << byte(c.b);
    return os.str();
}

struct Look {
    const char* kind;  // as the page groups and labels it
    unsigned rgb;
    double opacity;
};

// Glass translucent light blue (its ground butt ends and flats a darker, denser blue), mirrors
// light grey, mechanics dark grey, the stop black, imported meshes olive, detectors red: the
// colours of the 2D layout.
std::optional<Look> lookOf(ObjectKind k) {
    switch (k) {
        case ObjectKind::LensFace:
            return Look{"lens", 0x9ec9ea, 0.35};
        case ObjectKind::MirrorFace:
            return Look{"mirror", 0xc8ccd2, 0.9};
        case ObjectKind::LensEdge:
        case ObjectKind::LensFlat:
            return Look{"lens edge", 0x6f93b3, 0.6};
        case ObjectKind::Stop:
            return Look{"stop", 0x1a1a1a, 1.0};
        case ObjectKind::Mechanics:
            return Look{"mechanics", 0x5d6167, 1.0};
        case ObjectKind::ImportedMesh:
            return Look{"mesh", 0x8a8f3c, 1.0};
        case ObjectKind::Detector:
            return Look{"detector", 0xd03030, 0.9};
        case ObjectKind::Dummy:
            return std::nullopt;
    }
    return std::nullopt;
}

std::string floats(const std::vector<float>& v) { return base64(v.data(), v.size() * 4); }
std::string uints(const std::vector<uint32_t>& v) { return base64(v.data(), v.size() * 4); }

void push(std::vector<float>& out, const Vec3& p) {
    out.push_back(static_cast<float>(p.x));
    out.push_back(static_cast<float>(p.y));
    out.push_back(static_cast<float>(p.z));
}

nlohmann::json vec(const Vec3& p) { return nlohmann::json::array({p.x, p.y, p.z}); }

// A few rays of each source, from evenly spread uniforms: where it sits, which way it shines,
// and arrows from each origin to the first object met (or a tenth of the scene beyond).
nlohmann::json sourceMarkers(const Scene& scene, const std::vector<Source>& sources,
                             double sceneSizeMm) {
    nlohmann::json out = nlohmann::json::array();
    for (const Source& s : sources) {
        Vec3 centre(0.0), direction(0.0);
        std::vector<Ray> rays;
        for (double a : {0.125, 0.375, 0.625, 0.875})
            for (double b : {0.125, 0.375, 0.625, 0.875}) {
                const Ray r = s.emit({0.5, a, b, a, b}, 1).ray;
                rays.push_back(r);
                centre += r.origin;
                direction += r.direction;
            }
        centre /= static_cast<double>(rays.size());
        direction = glm::normalize(direction);
        double radius = 0.0;
        for (const Ray& r : rays) radius = std::max(radius, glm::length(r.origin - centre));
        std::vector<float> arrows;
        for (const Ray& r : rays) {
            const auto hit = scene.closestHit(r);
            const double t = hit ? hit->t : 0.1 * sceneSizeMm;
            push(arrows, r.origin);
            push(arrows, r.origin + t * r.direction);
        }
        out.push_back({{"name", s.name()},
                       {"kind", s.kind()},
                       {"position", vec(centre)},
                       {"direction", vec(direction)},
                       {"size_mm", 2.0 * radius},
                       {"rays", floats(arrows)},
                       {"ray_count", rays.size()}});
    }
    return out;
}

nlohmann::json pathData(const PathSelection& sel, const SceneViewOptions& o) {
    const double maxFlux = maxSegmentFlux(sel);
    struct Segment {
        Vec3 a, b;
        double flux;
        EventType event;
        uint64_t ray;
    };
    std::vector<Segment> segments;
    for (const SelectedRay& r : sel.rays)
        for (size_t k = 1; k < r.points.size(); ++k)
            segments.push_back(
                {r.points[r.parent[k]], r.points[k], r.flux[k], r.events[k].type, r.ray});
    // Weak segments first, so the strong ones are drawn over them.
    if (o.colouring == PathColouring::LogFlux)
        std::stable_sort(segments.begin(), segments.end(),
                         [](const Segment& x, const Segment& y) { return x.flux < y.flux; });
    std::vector<float> positions, logFlux;
    std::vector<uint8_t> colours;
    std::vector<uint32_t> rays;
    for (const Segment& s : segments) {
        push(positions, s.a);
        push(positions, s.b);
        const Color c = o.colouring == PathColouring::LogFlux
                            ? segmentFluxColour(s.flux, maxFlux, o.decades)
                            : eventColour(s.event);
        for (int v = 0; v < 2; ++v)
            for (double channel : {c.r, c.g, c.b})
                colours.push_back(
                    static_cast<uint8_t>(std::lround(std::clamp(channel, 0.0, 1.0) * 255.0)));
        // Ray indices beyond 32 bits are clamped (they only label the hover text).
        rays.push_back(static_cast<uint32_t>(std::min<uint64_t>(s.ray, UINT32_MAX)));
        // A segment that carries nothing (a culled branch's end) has no logarithm: -1e30
        // stands for it.
        logFlux.push_back(s.flux > 0.0 ? static_cast<float>(std::log10(s.flux)) : -1e30f);
    }
    nlohmann::json legend;
    if (o.colouring == PathColouring::LogFlux) {
        nlohmann::json stops = nlohmann::json::array();
        for (int i = 0; i <= 8; ++i) stops.push_back({i / 8.0, hexColour(falseColour(i / 8.0))});
        legend = {{"title", "segment flux, " + sel.fluxUnit + " per traced ray (log)"},
                  {"stops", stops},
                  {"min", maxFlux * std::pow(10.0, -o.decades)},
                  {"max", maxFlux}};
    } else {
        nlohmann::json keys = nlohmann::json::array();
        for (const auto& [label, t] : eventLegend())
            keys.push_back({label, hexColour(eventColour(t))});
        legend = {{"title", "segment colour: the event that ends it"}, {"events", keys}};
    }
    return {{"count", sel.pathCount()},
            {"rays", sel.rays.size()},
            {"criterion", sel.criterion},
            {"flux_unit", sel.fluxUnit},
            {"segments", segments.size()},
            {"positions", floats(positions)},
            {"colors", base64(colours.data(), colours.size())},
            {"ray_of_segment", uints(rays)},
            {"log10_flux_of_segment", floats(logFlux)},
            {"legend", legend}};
}

}  // namespace

std::string base64(const void* data, size_t bytes) {
    static constexpr char kAlphabet[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const auto* p = static_cast<const uint8_t*>(data);
    std::string out;
    out.reserve((bytes + 2) / 3 * 4);
    size_t i = 0;
    for (; i + 3 <= bytes; i += 3) {
        const uint32_t v = (uint32_t(p[i]) << 16) | (uint32_t(p[i + 1]) << 8) | p[i + 2];
        for (int s = 18; s >= 0; s -= 6) out.push_back(kAlphabet[(v >> s) & 63]);
    }
    if (const size_t rest = bytes - i; rest > 0) {
        const uint32_t v = (uint32_t(p[i]) << 16) | (rest == 2 ? uint32_t(p[i + 1]) << 8 : 0u);
        out.push_back(kAlphabet[(v >> 18) & 63]);
        out.push_back(kAlphabet[(v >> 12) & 63]);
        out.push_back(rest == 2 ? kAlphabet[(v >> 6) & 63] : '=');
        out.push_back('=');
    }
    return out;
}

nlohmann::json sceneViewData(const Scene& scene, const std::vector<Source>& sources,
                             const SceneViewOptions& o) {
    if (!(o.chordToleranceMm > 0.0)) throw std::invalid_argument("the chord tolerance must be > 0");
    if (!(o.decades > 0.0)) throw std::invalid_argument("decades must be > 0");
    std::vector<int> objectOf;
    const TriangleMesh mesh = scene.tessellate(o.chordToleranceMm, &objectOf);
    // Each object's triangles, its vertices renumbered from 0.
    struct Part {
        std::vector<float> positions;
        std::vector<uint32_t> indices;
        std::map<uint32_t, uint32_t> local;
    };
    std::vector<Part> parts(scene.objects().size());
    Bounds3 bounds;
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
        const int id = objectOf[t];
        if (id < 0 || !lookOf(scene.object(id).kind)) continue;
        Part& part = parts[id];
        for (uint32_t v : mesh.triangles[t]) {
            auto [it, added] =
                part.local.emplace(v, static_cast<uint32_t>(part.positions.size() / 3));
            if (added) {
                push(part.positions, mesh.vertices[v]);
                bounds.extend(mesh.vertices[v]);
            }
            part.indices.push_back(it->second);
        }
    }
    nlohmann::json objects = nlohmann::json::array();
    for (const SceneObject& obj : scene.objects()) {
        std::optional<Look> look = lookOf(obj.kind);
        if (!look) continue;
        if (obj.kind == ObjectKind::Detector && !o.detectors.empty())
            look = Look{"sensor surface", 0xe0a0a0, 0.35};
        const Part& part = parts[obj.id];
        objects.push_back({{"name", obj.name},
                           {"part", obj.part.empty() ? obj.name : obj.part},
                           {"kind", look->kind},
                           {"color", hexColour(Color::hex(look->rgb))},
                           {"opacity", look->opacity},
                           {"triangles", part.indices.size() / 3},
                           {"positions", floats(part.positions)},
                           {"indices", uints(part.indices)}});
    }
    // The grids: a rectangle each, a hair in front of the sensor surface on its sensitive side
    // so that the two do not fight for the same depth.
    const Look grid = *lookOf(ObjectKind::Detector);
    for (const DetectorGeometry& g : o.detectors) {
        if (!(g.widthMm > 0.0) || !(g.heightMm > 0.0)) continue;
        std::vector<float> positions;
        for (const Vec3& p : g.corners(-1e-3 * std::max(g.widthMm, g.heightMm))) {
            push(positions, p);
            bounds.extend(p);
        }
        const std::vector<uint32_t> indices{0, 1, 2, 0, 2, 3};
        objects.push_back({{"name", g.name},
                           {"part", g.name},
                           {"kind", grid.kind},
                           {"color", hexColour(Color::hex(grid.rgb))},
                           {"opacity", grid.opacity},
                           {"triangles", 2},
                           {"positions", floats(positions)},
                           {"indices", uints(indices)}});
    }
    const double size = bounds.empty() ? 1.0 : glm::length(bounds.hi - bounds.lo);
    nlohmann::json markers = sourceMarkers(scene, sources, size);
    for (const nlohmann::json& m : markers) {
        const auto& p = m["position"];
        bounds.extend(Vec3(p[0].get<double>(), p[1].get<double>(), p[2].get<double>()));
    }
    if (bounds.empty()) bounds.extend(Vec3(0.0));
    nlohmann::json data{{"title", o.title},
                        {"length_unit", "mm"},
                        {"flux_unit", sources.empty() ? "W" : unitSymbol(sources.front().unit())},
                        {"bounds", {{"min", vec(bounds.lo)}, {"max", vec(bounds.hi)}}},
                        {"objects", objects},
                        {"sources", markers}};
    if (o.paths) data["paths"] = pathData(*o.paths, o);
    return data;
}

ThreeJs loadThreeJs() {
    const char* env = std::getenv("VEIL_THREE_JS_DIR");
    const std::filesystem::path dir = env && *env
                                          ? std::filesystem::path(env)
                                          : std::filesystem::path("/usr/share/javascript/three");
    ThreeJs t;
    const std::pair<std::string*, const char*> files[] = {
        {&t.three, "build/three.min.js"},
        {&t.orbitControls, "examples/js/controls/OrbitControls.js"}};
    for (const auto& [text, name] : files) {
        const std::filesystem::path p = dir / name;
        if (!std::filesystem::is_regular_file(p))
            throw std::runtime_error(
                "three.js not found: no " + p.string() +
                " (install Debian's libjs-three, or set VEIL_THREE_JS_DIR to a folder holding "
                "build/three.min.js and examples/js/controls/OrbitControls.js)");
        const std::optional<std::string> bytes = readInputFile(p);
        if (!bytes) throw std::runtime_error(p.string() + ": cannot be read");
        *text = *bytes;
    }
    return t;
}

void writeSceneView(const std::filesystem::path& path, const nlohmann::json& data,
                    const ThreeJs& three) {
    // "</" never appears raw inside the data's script element: JSON may escape the slash.
    std::string json = data.dump();
    for (size_t at = json.find("</"); at != std::string::npos; at = json.find("</", at + 3))
        json.replace(at, 2, "<\\/");
    std::string page(detail::kSceneViewTemplate, detail::kSceneViewTemplateSize);
    const std::pair<const char*, const std::string*> slots[] = {
        {"/*VEIL_THREE_JS*/", &three.three},
        {"/*VEIL_ORBIT_CONTROLS_JS*/", &three.orbitControls},
        {"/*VEIL_SCENE_DATA*/", &json}};
    for (const auto& [slot, text] : slots) {
        const size_t at = page.find(slot);
        if (at == std::string::npos)
            throw std::logic_error(std::string("scene_view.html has no ") + slot);
        page.replace(at, std::string_view(slot).size(), *text);
    }
    writeTextFile(path, page);
}

}  // namespace veil
