#pragma once
// The interaction step every Monte Carlo pass shares: a ray meets a surface; what leaves it?
//
//   SceneHit + incoming direction + wavelength
//     -> SurfaceContext (normal turned toward the ray, n1 and n2 of the media on both sides,
//        opaque for mechanics, meshes, mirrors and detectors)
//     -> the object's OpticalProperty channels (tracer/surfaces/optical_property.h)
//     -> children: one per channel that carries flux, with its share of the arriving flux,
//        its medium, its event type, and its direction (specular children exactly; scattered
//        children sampled on demand from two uniforms, so a pass that culls a child before
//        using it may still draw them in a fixed order).
//
// Bookkeeping is exact: shares of the children + absorbed + dropped = 1 (to rounding).
//   absorbed  1 - (sum of the property's channels): the surface keeps it.
//   dropped   a channel the property gave flux to that has no direction here: a refraction
//             the channels count but Snell's law refuses (the property's TIR test and
//             refract() disagreeing at the critical angle), or a scatter channel whose
//             sampler returns no direction. Reported by reason, never mixed into absorbed,
//             so a lossless scene shows absorbed = 0 exactly.
// The pass decides what to do with the children: split into all of them, choose one
// (chooseChild), cull, play roulette, record events.

#include <cstdint>
#include <ostream>
#include <vector>

#include "geometry/scene.h"
#include "tracer/light/source.h"
#include "tracer/records/path_history.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/optical_property.h"

namespace veil {

class MediaOptics;

// What the transport needs of a scene, resolved once (tracer/scene/scene_transport.h fills it).
struct TransportView {
    const Scene* scene = nullptr;
    const MediaOptics* media = nullptr;
    std::vector<OpticalProperty> properties;  // distinct properties
    std::vector<int> propertyOfObject;        // [object id] -> index into properties
    std::vector<int> detectorOfObject;        // [object id] -> detector index, or -1
    // [detector index] -> the next detector on the same object, or -1: an object may carry any
    // number of detectors, each recording every hit (detectorOfObject names the first).
    std::vector<int> nextDetector;
    std::vector<std::string> detectorNames;   // [detector index] -> its name ([detector] name)
    std::vector<Source> sources;
};

// The detector after d on d's object in `next` (TransportView::nextDetector), -1 for none; a
// list shorter than d (a view built without it) has one detector an object.
inline int nextDetectorOf(const std::vector<int>& next, int d) {
    return static_cast<size_t>(d) < next.size() ? next[static_cast<size_t>(d)] : -1;
}

// Why a channel's share left the transport without a branch (see the header comment).
enum class DropReason : uint8_t {
    NoRefractedDirection = 0,
    NoScatterDirection = 1,
};
constexpr int kDropReasons = 2;
std::string_view toString(DropReason r);
std::ostream& operator<<(std::ostream& os, DropReason r);

struct InteractionChild {
    double share = 0.0;   // fraction of the arriving flux
    Vec3 direction{0.0};  // specular children; scattered ones: see Interaction::direction()
    int medium = 0;       // where the child travels
    bool scatter = false;
    bool transmit = false;
    EventType event = EventType::Refract;
};
std::ostream& operator<<(std::ostream& os, const InteractionChild& c);

struct Interaction {
    SurfaceContext context;
    const OpticalProperty* property = nullptr;
    InteractionChild children[4];
    int count = 0;
    double total = 0.0;     // sum of the children's shares
    double absorbed = 0.0;  // share the surface absorbs
    double dropped = 0.0;   // share of channels without a direction
    DropReason dropReason = DropReason::NoRefractedDirection;  // when dropped > 0

    // The direction of child k: its specular direction, or a scattered one drawn with two
    // uniforms from rng. A scatter channel that yields no direction returns nullopt (the
    // pass books the child's share as dropped with DropReason::NoScatterDirection).
    std::optional<Vec3> direction(int k, CounterRng& rng) const;
};
std::ostream& operator<<(std::ostream& os, const Interaction& in);

// Whether an object's kind makes it opaque to the transport (nothing is transmitted).
bool isOpaqueKind(ObjectKind k);

// The interaction of a ray travelling along `direction` with the surface it hit, at
// wavelength index w of the media (wavelengthNm for the coatings). Not for detector objects:
// those absorb and record, which is the pass's business.
//
// mode: Flux (a forward photon) gives the shares above. Importance (a backward ray from a
// pixel, tracer/surfaces/optical_property.h) gives the specular children the weights of the
// adjoint, specularReflectWeight / specularTransmitWeight (the n^2 rule at refraction), so they no
// longer add up with `absorbed` to 1; scatter children keep their flux fractions, and a
// backward pass that continues through scatter weights each sampled direction by
// bsdf(..., Importance) cos / pdf itself.
Interaction interact(const TransportView& ts, const SceneHit& hit, const Vec3& direction, int w,
                     double wavelengthNm, TransportMode mode = TransportMode::Flux);

// One child chosen with probability proportional to its share, from one uniform u in [0, 1).
// The chosen child then carries the whole non-absorbed flux (total): unbiased.
int chooseChild(const Interaction& in, double u);
// The scattered children's shares together, and one of them chosen in proportion to its share
// from one uniform u in [0, 1) (-1 when none scatters).
double scatteredShare(const Interaction& in);
int chooseScatterChild(const Interaction& in, double u);

// Russian roulette: a flux below `below` survives with probability flux / keep (keep >=
// below) and then carries `keep`; returns the flux to carry on, 0 when it dies. Draws one
// uniform, only when the flux is below `below`, so a stream is unchanged when it does not.
inline double playRoulette(double flux, double below, double keep, CounterRng& rng) {
    if (!(flux < below)) return flux;
    return rng.uniform() * keep < flux ? keep : 0.0;
}

}  // namespace veil
