#include "tracer/transport/interaction.h"

#include <algorithm>

#include "tracer/records/path_history.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/surfaces/media.h"

namespace veil {

std::string_view toString(DropReason r) {
    switch (r) {
        case DropReason::NoRefractedDirection:
            return "no refracted direction";
        case DropReason::NoScatterDirection:
            return "no scatter direction";
    }
    return "?";
}

std::ostream& operator<<(std::ostream& os, DropReason r) { return os << toString(r); }

std::ostream& operator<<(std::ostream& os, const InteractionChild& c) {
    os << "InteractionChild{" << c.event << " share " << c.share << " medium " << c.medium;
    if (!c.scatter) os << " direction " << c.direction;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const Interaction& in) {
    os << "Interaction{" << in.context << ", absorbed " << in.absorbed << ", dropped "
       << in.dropped;
    for (int k = 0; k < in.count; ++k) os << ", " << in.children[k];
    return os << "}";
}

bool isOpaqueKind(ObjectKind k) {
    return k == ObjectKind::Mechanics || k == ObjectKind::Stop || k == ObjectKind::ImportedMesh ||
           k == ObjectKind::MirrorFace || k == ObjectKind::Detector;
}

Interaction interact(const TransportView& ts, const SceneHit& hit, const Vec3& direction, int w,
                     double wavelengthNm, TransportMode mode) {
    Interaction in;
    const SceneObject& obj = ts.scene->object(hit.object);
    const OpticalProperty& prop = ts.properties[ts.propertyOfObject[hit.object]];
    in.property = &prop;
    SurfaceContext& ctx = in.context;
    ctx.direction = direction;
    ctx.normal = hit.fromFront ? hit.normal : -hit.normal;
    ctx.n1 = ts.media->index(hit.mediumFrom, w);
    ctx.n2 = ts.media->index(hit.mediumTo, w);
    ctx.wavelengthNm = wavelengthNm;
    ctx.opaque = isOpaqueKind(obj.kind);
    const Channels ch = prop.channels(ctx);

    // A reflection at an interface that also refracts is a ghost's first step.
    const EventType specularEvent =
        ch.tir ? EventType::TotalInternalReflection
        : (obj.kind == ObjectKind::LensFace && !ctx.opaque && ctx.n1 != ctx.n2)
            ? EventType::FresnelReflect
            : EventType::SpecularReflect;
    auto add = [&](double share, const Vec3& d, int medium, bool scatter, bool transmit,
                   EventType event) {
        // Field by field into place: a temporary copied in whole would be read back through
        // wider loads than it was written with, which stalls store forwarding.
        InteractionChild& c = in.children[in.count++];
        c.share = share;
        c.direction = d;
        c.medium = medium;
        c.scatter = scatter;
        c.transmit = transmit;
        c.event = event;
    };
    const bool importance = mode == TransportMode::Importance;
    if (ch.specularReflect > 0.0)
        add(importance ? prop.specularReflectWeight(ctx, mode) : ch.specularReflect,
            reflect(direction, ctx.normal), hit.mediumFrom, false, false, specularEvent);
    if (ch.specularTransmit > 0.0) {
        Vec3 t;
        if (refractInto(direction, ctx.normal, ctx.n1, ctx.n2, t)) {
            add(importance ? prop.specularTransmitWeight(ctx, mode) : ch.specularTransmit, t,
                hit.mediumTo, false, true, EventType::Refract);
        } else {
            in.dropped += ch.specularTransmit;
            in.dropReason = DropReason::NoRefractedDirection;
        }
    }
    if (ch.scatterReflect > 0.0)
        add(ch.scatterReflect, Vec3(0.0), hit.mediumFrom, true, false, EventType::ScatterReflect);
    if (ch.scatterTransmit > 0.0)
        add(ch.scatterTransmit, Vec3(0.0), hit.mediumTo, true, true, EventType::ScatterTransmit);
    for (int k = 0; k < in.count; ++k) in.total += in.children[k].share;
    in.absorbed = std::max(0.0, 1.0 - ch.sum());
    return in;
}

std::optional<Vec3> Interaction::direction(int k, CounterRng& rng) const {
    const InteractionChild& c = children[k];
    if (!c.scatter) return c.direction;
    const double u1 = rng.uniform(), u2 = rng.uniform();
    const ScatterSample s = property->sampleScatter(context, c.transmit, u1, u2);
    if (!(s.pdf > 0.0)) return std::nullopt;
    return s.direction;
}

int chooseChild(const Interaction& in, double u) {
    const double x = u * in.total;
    double c = 0.0;
    int k = 0;
    for (; k < in.count - 1; ++k) {
        c += in.children[k].share;
        if (x < c) break;
    }
    return k;
}

double scatteredShare(const Interaction& in) {
    double s = 0.0;
    for (int c = 0; c < in.count; ++c)
        if (in.children[c].scatter) s += in.children[c].share;
    return s;
}

int chooseScatterChild(const Interaction& in, double u) {
    double x = u * scatteredShare(in);
    int chosen = -1;
    for (int k = 0; k < in.count; ++k) {
        if (!in.children[k].scatter) continue;
        chosen = k;
        x -= in.children[k].share;
        if (x < 0.0) break;
    }
    return chosen;
}

}  // namespace veil
