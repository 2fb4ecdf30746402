#include "analysis/layout.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "analysis/scene_section.h"

namespace veil {

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

}  // namespace

Picture drawLayout(const Scene& scene, const LayoutOptions& options) {
    const std::vector<SectionPath> paths = sceneSection(scene, options.chordToleranceMm);
    Bounds3 b;
    for (const SectionPath& p : paths)
        for (const Vec2& zy : p.zy) b.extend(Vec3(0.0, zy.y, zy.x));
    if (b.empty()) b.extend(Vec3(0.0, -1.0, -1.0)), b.extend(Vec3(0.0, 1.0, 1.0));
    const double pad = 0.04 * std::max(b.hi.z - b.lo.z, b.hi.y - b.lo.y);
    Picture pic(b.lo.z - pad, b.hi.z + pad, b.lo.y - pad, b.hi.y + pad);

    // Optical axis first, under everything.
    pic.polyline({Vec2(b.lo.z - pad, 0.0), Vec2(b.hi.z + pad, 0.0)}, Color::hex(0x888888), 0.6,
                 true);
    // Filled parts in an order that keeps thin parts visible: glass, mechanics, stop.
    auto rank = [](ObjectKind k) {
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
    };
    std::vector<const SectionPath*> order;
    for (const SectionPath& p : paths) order.push_back(&p);
    std::stable_sort(order.begin(), order.end(), [&](const SectionPath* a, const SectionPath* c) {
        return rank(a->kind) < rank(c->kind);
    });
    std::map<std::string, Bounds3> partBounds;
    for (const SectionPath* p : order) {
        const Style st = styleFor(p->kind);
        if (p->closed)
            pic.polygon(p->zy, st.fill, st.stroke, st.width);
        else
            pic.polyline(p->zy, st.stroke, st.width);
        if (p->kind == ObjectKind::LensFace || p->kind == ObjectKind::LensEdge ||
            p->kind == ObjectKind::LensFlat || p->kind == ObjectKind::MirrorFace)
            for (const Vec2& zy : p->zy) partBounds[p->part].extend(Vec3(0.0, zy.y, zy.x));
    }
    if (options.labels) {
        // Element names above each element.
        for (const auto& [part, pb] : partBounds)
            pic.text(0.5 * (pb.lo.z + pb.hi.z), pb.hi.y + 0.35 * pad, part, Color::hex(0x1f3f6f),
                     10.0);
    }
    if (!options.title.empty())
        pic.overlayText(pic.marginPt, 24.0, options.title, Color::hex(0x000000), 14.0);
    pic.scaleBar();
    return pic;
}

}  // namespace veil
