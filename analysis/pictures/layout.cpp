#include "analysis/pictures/layout.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "analysis/pictures/scene_section.h"
#include "geometry/scene.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

// Layout Sources

std::ostream& operator<<(std::ostream& os, const LayoutSource& s) {
    os << "LayoutSource{'" << s.name << "', " << s.kind << ", emitter";
    for (const Vec2& p : s.emitterZY) os << " (" << p.x << ", " << p.y << ")";
    os << ", '" << s.detail << "', " << s.arrows.size() << " arrows:";
    for (const LayoutSource::Arrow& a : s.arrows)
        os << " (" << a.fromZY.x << ", " << a.fromZY.y << ")->(" << a.toZY.x << ", " << a.toZY.y
           << ")";
    return os << "}";
}

namespace {

Vec2 zy(const Vec3& p) { return Vec2(p.z, p.y); }

// An angle in degrees to 3 significant digits ("7", "3.25", "0.533").
std::string degrees(double rad) {
    std::ostringstream os;
    os << std::setprecision(3) << rad * 180.0 / M_PI << " deg";
    return os.str();
}

constexpr double kConeFill = 0.9;              // of a point source's cone drawn
constexpr double kMaxAreaRayRad = M_PI / 4.0;  // steepest ray drawn from an area source

// The unit vector perpendicular to `axis` closest to +y (the direction a y-z section
// shows best); `fallback` when the axis is along y.
Vec3 towardY(const Vec3& axis, const Vec3& fallback) {
    const Vec3 y(0.0, 1.0, 0.0);
    const Vec3 w = y - glm::dot(y, axis) * axis;
    const double len = glm::length(w);
    return len > 1e-9 ? w / len : fallback;
}

// What a ray from `origin` along `direction` meets first: the hit's distance, or `far` (past
// the scene's bounds) when it meets nothing.
double firstHitDistance(const Scene& scene, const Vec3& origin, const Vec3& direction, double far) {
    const std::optional<SceneHit> hit = scene.closestHit(Ray{origin, direction});
    return hit ? hit->t : far;
}

// A distance from `origin` that is past everything in the scene.
double beyondScene(const Scene& scene, const Vec3& origin) {
    const Bounds3 b = scene.bounds();
    if (b.empty()) return 100.0;
    return glm::length(b.hi - b.lo) + glm::length(0.5 * (b.hi + b.lo) - origin);
}

LayoutSource beamSource(const Beam& beam, const Scene& scene, int rays, double minArrowMm) {
    LayoutSource s;
    const Vec3 d = beam.direction;
    const Vec3 w = towardY(d, beam.axisV);
    std::vector<Vec3> origins;
    std::vector<double> lengths;
    for (int i = 0; i < rays; ++i) {
        const double f = rays == 1 ? 0.0 : 2.0 * i / (rays - 1) - 1.0;
        const Vec3 o = beam.startCenterMm + f * beam.radiusMm * w;
        origins.push_back(o);
        lengths.push_back(firstHitDistance(scene, o, d, beyondScene(scene, o)));
    }
    const double shortest = *std::min_element(lengths.begin(), lengths.end());
    const double setBack = std::max(0.0, minArrowMm - shortest);
    for (size_t i = 0; i < origins.size(); ++i)
        s.arrows.push_back({zy(origins[i] - setBack * d), zy(origins[i] + lengths[i] * d)});
    const double offAxis = std::acos(std::clamp(d.z, -1.0, 1.0));
    if (offAxis > 1e-9) s.detail = degrees(offAxis) + " off axis";
    return s;
}

LayoutSource pointSource(const PointSource& p, const Scene& scene, int rays) {
    LayoutSource s;
    s.emitterZY.push_back(zy(p.positionMm));
    const Vec3 w = towardY(p.axis, p.axisV);
    const double far = beyondScene(scene, p.positionMm);
    // A whole sphere: evenly around the circle; else evenly over 90 % of [-half, half]: the
    // edge of a cone that covers the first surface grazes its rim and would fly past it.
    const bool sphere = p.halfAngleRad >= M_PI * (1.0 - 1e-9);
    s.detail = sphere ? "whole sphere" : "+-" + degrees(p.halfAngleRad) + " cone";
    for (int i = 0; i < rays; ++i) {
        const double phi = sphere      ? 2.0 * M_PI * i / rays
                           : rays == 1 ? 0.0
                                       : kConeFill * p.halfAngleRad * (2.0 * i / (rays - 1) - 1.0);
        const Vec3 dir = std::cos(phi) * p.axis + std::sin(phi) * w;
        const double t = firstHitDistance(scene, p.positionMm, dir, far);
        s.arrows.push_back({zy(p.positionMm), zy(p.positionMm + t * dir)});
    }
    return s;
}

LayoutSource areaSource(const AreaEmitter& a, const Scene& scene) {
    LayoutSource s;
    const Vec3 centre = a.frame.toGlobalPoint(Vec3(0.0));
    const Vec3 normal = glm::normalize(a.frame.toGlobalDirection(Vec3(0.0, 0.0, 1.0)));
    const Vec3 ex = a.frame.toGlobalDirection(Vec3(1.0, 0.0, 0.0));
    const Vec3 w = towardY(normal, a.frame.toGlobalDirection(Vec3(0.0, 1.0, 0.0)));
    // Half the section's length along w: the disk's radius, or where the line through the
    // rectangle's centre along w leaves it.
    double half = a.radiusMm;
    if (a.shape == AreaEmitter::Shape::Rectangle) {
        const double wx = std::abs(glm::dot(w, ex)),
                     wy = std::abs(glm::dot(w, a.frame.toGlobalDirection(Vec3(0.0, 1.0, 0.0))));
        half = std::min(wx > 1e-12 ? 0.5 * a.sizeMm.x / wx : kInfinity,
                        wy > 1e-12 ? 0.5 * a.sizeMm.y / wy : kInfinity);
    }
    s.emitterZY = {zy(centre - half * w), zy(centre + half * w)};
    auto ray = [&](const Vec3& o, double phi) {
        const Vec3 dir = std::cos(phi) * normal + std::sin(phi) * w;
        s.arrows.push_back(
            {zy(o), zy(o + firstHitDistance(scene, o, dir, beyondScene(scene, o)) * dir)});
    };
    for (double f : {-1.0, 0.0, 1.0}) ray(centre + f * half * w, 0.0);
    if (a.coneHalfAngleRad < 0.5 * M_PI * (1.0 - 1e-9))
        s.detail = "+-" + degrees(a.coneHalfAngleRad) + " cone";
    const double cone = std::min(a.coneHalfAngleRad, kMaxAreaRayRad);
    ray(centre, -cone);
    ray(centre, cone);
    return s;
}

}  // namespace

std::vector<LayoutSource> layoutSources(const std::vector<Source>& sources, const Scene& scene,
                                        const LayoutSourceOptions& options) {
    if (options.beamRays < 1 || options.coneRays < 1)
        throw std::invalid_argument("layoutSources: beamRays and coneRays must be >= 1");
    double minArrow = options.minBeamArrowMm;
    if (!(minArrow > 0.0)) {
        const Bounds3 b = scene.bounds();
        minArrow = b.empty() ? 10.0 : 0.08 * std::max(b.hi.z - b.lo.z, b.hi.y - b.lo.y);
    }
    std::vector<LayoutSource> out;
    for (const Source& src : sources) {
        LayoutSource s = std::visit(
            [&](const auto& k) {
                using T = std::decay_t<decltype(k)>;
                if constexpr (std::is_same_v<T, CollimatedSource> || std::is_same_v<T, SunSource>)
                    return beamSource(k.beam, scene, options.beamRays, minArrow);
                else if constexpr (std::is_same_v<T, PointSource>)
                    return pointSource(k, scene, options.coneRays);
                else
                    return areaSource(k.area, scene);
            },
            src.shape());
        s.name = src.name();
        s.kind = src.kind();
        out.push_back(std::move(s));
    }
    return out;
}

// Layout Drawing

namespace {

struct Style {
    Color fill;
    Color stroke;
    double width;
};

Style styleFor(ObjectKind k) {
    switch (k) {
        case ObjectKind::LensFace:
        case ObjectKind::LensEdge:
        case ObjectKind::LensFlat:
            return {Color::hex(0xcfe6ff), Color::hex(0x1f5fa8), 0.8};
        case ObjectKind::MirrorFace:
            return {Color::hex(0xd8d8d8), Color::hex(0x303030), 1.6};
        case ObjectKind::Stop:
            return {Color::hex(0x202020), Color::hex(0x000000), 0.6};
        case ObjectKind::Mechanics:
            return {Color::hex(0x9a9a9a), Color::hex(0x505050), 0.6};
        case ObjectKind::ImportedMesh:
            return {Color::hex(0xb5b36a), Color::hex(0x6b6a2e), 0.6};
        case ObjectKind::Detector:
            return {Color::hex(0xffffff), Color::hex(0xd62728), 1.6};
        case ObjectKind::Dummy:
            return {Color::hex(0xffffff), Color::hex(0xaaaaaa), 0.5};
    }
    return {Color::hex(0xffffff), Color::hex(0x000000), 0.5};
}

const Color kSourceColour = Color::hex(0xe8710a);
const Color kAxisColour = Color::hex(0x888888);
const Color kElementLabelColour = Color::hex(0x1f3f6f);
const Color kSourceLabelColour = Color::hex(0xa04e00);

// Legend groups, in legend order: what a kind of object is called there.
enum class Group { Glass, Mirror, Mechanics, Mesh, Stop, Detector, Dummy };

Group groupOf(ObjectKind k) {
    switch (k) {
        case ObjectKind::LensFace:
        case ObjectKind::LensEdge:
        case ObjectKind::LensFlat:
            return Group::Glass;
        case ObjectKind::MirrorFace:
            return Group::Mirror;
        case ObjectKind::Mechanics:
            return Group::Mechanics;
        case ObjectKind::ImportedMesh:
            return Group::Mesh;
        case ObjectKind::Stop:
            return Group::Stop;
        case ObjectKind::Detector:
            return Group::Detector;
        case ObjectKind::Dummy:
            return Group::Dummy;
    }
    return Group::Dummy;
}

// `filled`: the group was drawn as closed outlines (else as lines only, like a mirror's
// section or a detector).
// With detector grids drawn: the surface a grid lies on, pale and thin, and the grid thick.
const Color kSensorSurfaceColour = Color::hex(0xe0a0a0);
constexpr double kGridWidth = 3.0;

LegendEntry legendEntry(Group g, bool filled) {
    static const std::map<Group, std::pair<const char*, ObjectKind>> kNames = {
        {Group::Glass, {"glass", ObjectKind::LensFace}},
        {Group::Mirror, {"mirror", ObjectKind::MirrorFace}},
        {Group::Mechanics, {"mechanics", ObjectKind::Mechanics}},
        {Group::Mesh, {"imported mesh", ObjectKind::ImportedMesh}},
        {Group::Stop, {"aperture stop", ObjectKind::Stop}},
        {Group::Detector, {"detector", ObjectKind::Detector}},
        {Group::Dummy, {"dummy surface", ObjectKind::Dummy}}};
    const auto& [label, kind] = kNames.at(g);
    const Style st = styleFor(kind);
    if (!filled) return {label, LegendEntry::Swatch::Line, {}, st.stroke, std::max(st.width, 1.6)};
    return {label, LegendEntry::Swatch::Fill, st.fill, st.stroke, 0.8};
}

// Labels that would overlap their left neighbour (same height, text boxes crossing) move up
// one line at a time. Positions are model (z, y); widths come from the page scale.
struct Label {
    Vec2 at;
    std::string text;
    Color colour;
    TextAnchor anchor = TextAnchor::Middle;
    // Left and right ends (mm) for a text width in mm.
    std::pair<double, double> span(double widthMm) const {
        const double left = anchor == TextAnchor::Start    ? at.x
                            : anchor == TextAnchor::Middle ? at.x - 0.5 * widthMm
                                                           : at.x - widthMm;
        return {left, left + widthMm};
    }
};
void placeLabels(std::vector<Label>& labels, double mmPerPt, double sizePt) {
    std::stable_sort(labels.begin(), labels.end(),
                     [](const Label& a, const Label& b) { return a.at.x < b.at.x; });
    const double lineMm = 1.2 * sizePt * mmPerPt, gapMm = 2.0 * mmPerPt;
    std::vector<double> widthMm;
    for (const Label& l : labels) widthMm.push_back(Picture::textWidthPt(l.text, sizePt) * mmPerPt);
    for (size_t i = 0; i < labels.size(); ++i) {
        for (bool moved = true; moved;) {
            moved = false;
            for (size_t j = 0; j < i; ++j) {
                const auto [a0, a1] = labels[i].span(widthMm[i]);
                const auto [b0, b1] = labels[j].span(widthMm[j]);
                const bool crossX = a0 < b1 + gapMm && b0 < a1 + gapMm;
                // (A label moved onto y_j + line must not cross j again by rounding.)
                const bool crossY = std::abs(labels[i].at.y - labels[j].at.y) < 0.999 * lineMm;
                if (crossX && crossY) {
                    labels[i].at.y = labels[j].at.y + lineMm;
                    moved = true;
                }
            }
        }
    }
}

// The frame: the section's bounds, grown to take in where sources start, by at most half the
// section's larger extent on each side.
Bounds3 layoutBounds(const std::vector<SectionPath>& paths,
                     const std::vector<LayoutSource>& sources) {
    Bounds3 b;
    for (const SectionPath& p : paths)
        for (const Vec2& q : p.zy) b.extend(Vec3(0.0, q.y, q.x));
    if (b.empty()) b.extend(Vec3(0.0, -1.0, -1.0)), b.extend(Vec3(0.0, 1.0, 1.0));
    const double reach = 0.5 * std::max(b.hi.z - b.lo.z, b.hi.y - b.lo.y);
    const Bounds3 section = b;
    auto take = [&](const Vec2& q) {
        b.extend(Vec3(0.0, std::clamp(q.y, section.lo.y - reach, section.hi.y + reach),
                      std::clamp(q.x, section.lo.z - reach, section.hi.z + reach)));
    };
    for (const LayoutSource& s : sources) {
        for (const Vec2& q : s.emitterZY) take(q);
        for (const LayoutSource::Arrow& a : s.arrows) take(a.fromZY);
    }
    return b;
}

// Draws the source; returns its label (placed with the others) when it shows anything.
std::optional<Label> drawSource(Picture& pic, const LayoutSource& s, double padMm) {
    const double zMin = pic.zMin(), zMax = pic.zMax(), yMin = pic.yMin(), yMax = pic.yMax();
    std::optional<Vec2> labelAt;  // the highest start drawn
    for (const LayoutSource::Arrow& a : s.arrows) {
        Vec2 p = a.fromZY, q = a.toZY;
        if (!clipSegment(p, q, zMin, zMax, yMin, yMax)) continue;
        if (glm::length(q - p) > 0.0) pic.arrow(p, q, kSourceColour, 1.0, 7.0);
        if (!labelAt || p.y > labelAt->y) labelAt = p;
    }
    const auto inside = [&](const Vec2& p) {
        return p.x >= zMin && p.x <= zMax && p.y >= yMin && p.y <= yMax;
    };
    if (s.emitterZY.size() == 1 && inside(s.emitterZY[0])) {
        pic.dot(s.emitterZY[0], 3.5, kSourceColour, Color::hex(0x7a3a00));
        labelAt = s.emitterZY[0];
    } else if (s.emitterZY.size() == 2) {
        Vec2 p = s.emitterZY[0], q = s.emitterZY[1];
        if (clipSegment(p, q, zMin, zMax, yMin, yMax)) {
            pic.polyline({p, q}, kSourceColour, 3.0);
            labelAt = p.y > q.y ? p : q;
        }
    }
    if (!labelAt) return std::nullopt;
    std::string text = s.name == s.kind ? s.name : s.name + " (" + s.kind + ")";
    if (!s.detail.empty()) text += ", " + s.detail;
    return Label{Vec2(labelAt->x, labelAt->y + 0.3 * padMm), text, kSourceLabelColour,
                 TextAnchor::Start};
}

int rank(ObjectKind k) {
    // Filled parts in an order that keeps thin parts visible: mechanics, glass, stop.
    switch (k) {
        case ObjectKind::Mechanics:
        case ObjectKind::ImportedMesh:
            return 0;
        case ObjectKind::LensFace:
        case ObjectKind::LensEdge:
        case ObjectKind::LensFlat:
            return 1;
        case ObjectKind::Stop:
            return 2;
        default:
            return 3;
    }
}

}  // namespace

std::vector<Vec3> layoutAxis(const SequentialModel& model) {
    std::vector<Vec3> out;
    if (model.coaxial()) return out;
    for (int i = 1; i < model.surfaceCount(); ++i)
        if (!model.surface(i).coordinateBreak) out.push_back(model.surface(i).frame.translation);
    return out;
}

Picture drawLayout(const Scene& scene, const LayoutOptions& options) {
    const std::vector<SectionPath> paths = sceneSection(scene, options.chordToleranceMm);
    const Bounds3 extent = layoutBounds(paths, options.sources);
    const double pad = 0.04 * std::max(extent.hi.z - extent.lo.z, extent.hi.y - extent.lo.y);
    Picture pic(extent.lo.z - pad, extent.hi.z + pad, extent.lo.y - pad, extent.hi.y + pad);
    const double mmPerPt = (pic.zMax() - pic.zMin()) / (Picture::kPageWidthPt - 2.0 * pic.marginPt);

    // Optical axis first, under everything.
    if (options.axisVerticesMm.empty()) {
        pic.polyline({Vec2(pic.zMin(), 0.0), Vec2(pic.zMax(), 0.0)}, kAxisColour, 0.6, true);
    } else {
        // Segment by segment, each drawn once: light that goes back along the axis (after a
        // mirror) would lay a second dash pattern over the first.
        // From the picture's left edge when surface 1 lies inside the picture.
        std::vector<Vec2> axis;
        if (pic.zMin() < options.axisVerticesMm.front().z) axis.emplace_back(pic.zMin(), 0.0);
        for (const Vec3& v : options.axisVerticesMm) axis.emplace_back(v.z, v.y);
        const double tol = 1e-9 * (pic.zMax() - pic.zMin());
        auto onSegment = [&](const Vec2& q, const Vec2& a, const Vec2& b) {
            const Vec2 ab = b - a;
            const double len2 = glm::dot(ab, ab);
            const double t = len2 > 0.0 ? std::clamp(glm::dot(q - a, ab) / len2, 0.0, 1.0) : 0.0;
            return glm::length(a + t * ab - q) <= tol;
        };
        std::vector<std::pair<Vec2, Vec2>> drawnSegments;
        for (size_t k = 1; k < axis.size(); ++k) {
            const Vec2 a = axis[k - 1], b = axis[k];
            if (glm::length(b - a) <= tol) continue;
            bool covered = false;
            for (const auto& [p, q] : drawnSegments)
                covered = covered || (onSegment(a, p, q) && onSegment(b, p, q));
            if (covered) continue;
            pic.polyline({a, b}, kAxisColour, 0.6, true);
            drawnSegments.emplace_back(a, b);
        }
    }
    std::vector<const SectionPath*> order;
    for (const SectionPath& p : paths) order.push_back(&p);
    std::stable_sort(order.begin(), order.end(), [&](const SectionPath* a, const SectionPath* c) {
        return rank(a->kind) < rank(c->kind);
    });
    std::map<std::string, Bounds3> partBounds, detectorBounds;
    std::map<Group, bool> drawn;  // group -> some of it drawn filled
    const bool grids = !options.detectors.empty();
    for (const SectionPath* p : order) {
        if (p->zy.size() < 2) continue;
        Style st = styleFor(p->kind);
        if (grids && p->kind == ObjectKind::Detector) {
            st.stroke = kSensorSurfaceColour;
            st.width = 0.8;
        }
        if (p->closed)
            pic.polygon(p->zy, st.fill, st.stroke, st.width);
        else
            pic.polyline(p->zy, st.stroke, st.width);
        const Group g = groupOf(p->kind);
        drawn[g] = drawn[g] || p->closed;
        auto& bounds = g == Group::Detector ? detectorBounds : partBounds;
        if (g == Group::Glass || g == Group::Mirror || g == Group::Detector)
            for (const Vec2& q : p->zy) bounds[p->part].extend(Vec3(0.0, q.y, q.x));
    }
    for (const LayoutDetector& d : options.detectors)
        pic.polyline({d.fromZY, d.toZY}, styleFor(ObjectKind::Detector).stroke, kGridWidth);
    std::vector<Label> labels;
    for (const LayoutSource& s : options.sources)
        if (std::optional<Label> l = drawSource(pic, s, pad)) labels.push_back(*l);

    if (options.labels) {
        // Element names above each element, the detector's name above its top end, source
        // names above where they start; moved up where they would overlap.
        for (const auto& [part, pb] : partBounds)
            labels.push_back(
                {Vec2(0.5 * (pb.lo.z + pb.hi.z), pb.hi.y + 0.35 * pad), part, kElementLabelColour});
        for (const auto& [part, pb] : detectorBounds)
            labels.push_back({Vec2(0.5 * (pb.lo.z + pb.hi.z), pb.hi.y + 0.35 * pad), part,
                              styleFor(ObjectKind::Detector).stroke});
        placeLabels(labels, mmPerPt, 10.0);
        for (const Label& l : labels)
            pic.text(l.at.x, l.at.y, l.text, l.colour, 10.0, l.anchor, /*halo=*/true);
    }
    if (!options.title.empty()) pic.title(options.title);
    pic.scaleBar();

    std::vector<LegendEntry> legend;
    for (const auto& [g, filled] : drawn) {
        if (g == Group::Detector && grids) {
            legend.push_back(
                {"sensor surface", LegendEntry::Swatch::Line, {}, kSensorSurfaceColour, 1.6});
            continue;
        }
        legend.push_back(legendEntry(g, filled));
    }
    if (grids)
        legend.push_back({"detector (recorded area)",
                          LegendEntry::Swatch::Line,
                          {},
                          styleFor(ObjectKind::Detector).stroke,
                          kGridWidth});
    legend.push_back({"optical axis", LegendEntry::Swatch::DashedLine, {}, kAxisColour, 0.8});
    if (!options.sources.empty())
        legend.push_back({"source", LegendEntry::Swatch::Arrow, {}, kSourceColour, 1.0});
    pic.legend(std::move(legend));
    return pic;
}

std::vector<LayoutDetector> layoutDetectors(const std::vector<DetectorGeometry>& grids) {
    std::vector<LayoutDetector> out;
    for (const DetectorGeometry& g : grids) {
        if (!(g.widthMm > 0.0) || !(g.heightMm > 0.0)) continue;
        const std::array<Vec3, 4> corners = g.corners();
        // Where the rectangle's edges cross x = 0 (an edge in the plane gives its ends).
        std::vector<Vec2> cut;
        for (int e = 0; e < 4; ++e) {
            const Vec3& a = corners[e];
            const Vec3& b = corners[(e + 1) % 4];
            if (a.x == 0.0) cut.emplace_back(a.z, a.y);
            if ((a.x < 0.0 && b.x > 0.0) || (a.x > 0.0 && b.x < 0.0)) {
                const double t = a.x / (a.x - b.x);
                const Vec3 p = a + t * (b - a);
                cut.emplace_back(p.z, p.y);
            }
        }
        if (cut.size() < 2) continue;
        // The two points furthest apart.
        LayoutDetector d{g.name, cut[0], cut[1]};
        double best = -1.0;
        for (size_t i = 0; i < cut.size(); ++i)
            for (size_t j = i + 1; j < cut.size(); ++j) {
                const double dist = glm::length(cut[i] - cut[j]);
                if (dist > best) {
                    best = dist;
                    d.fromZY = cut[i];
                    d.toZY = cut[j];
                }
            }
        out.push_back(d);
    }
    return out;
}

}  // namespace veil
