#pragma once
// Path criteria as the renderer sees them (tracer/render/render.h). A rendered path is joined from
// two halves traced at different times: the forward half (a photon's events from its emission to
// the surface where a view point gathers it, or a source sampled from a view point) and the
// backward half (the view point's specular events back to the detector, reversed into the
// order light travels them). The criteria module (analysis/criteria/render_criteria.h) implements
// this interface with the seed's three-state evaluator; the tracer knows only this, as it knows
// only BranchFilter for the forward tracer's pruning.
//
//   photon:   Emit(sun) Refract(L1.front) ... ScatterReflect(spacer2) ─┐ prefix state
//   backward:                          [ScatterReflect(spacer2)] Refract(L6.front) ...
//                                       DetectorHit(sensor)         ─┘ suffix events
//
// The prefix is streamed (push), the suffix is judged against a copy of the prefix state
// (matches); a prefix whose criteria are all decided false can stop the photon (pruning), and
// a suffix no prefix can complete to a match can stop the backward branch (suffixMayMatch).

#include <cstddef>
#include <cstdint>
#include <span>

#include "tracer/records/path_history.h"

namespace veil {

// The event of type `type` at `object` (a source index for Emit) and `face`, the light going
// from medium `before` into `after`: how the renderer and the forward tracer's online filter
// write the events they judge.
inline PathEvent pathEvent(EventType type, int object, int face, int before, int after) {
    PathEvent e;
    e.type = type;
    e.object = object;
    e.face = face;
    e.mediumBefore = static_cast<int16_t>(before);
    e.mediumAfter = static_cast<int16_t>(after);
    return e;
}

class PathJudge {
  public:
    virtual ~PathJudge() = default;
    // How many criteria (bit c of the masks below is criterion c); at most 64.
    virtual int count() const = 0;
    // Bytes of one prefix state.
    virtual size_t stateBytes() const = 0;
    // The state of an empty path (before its Emit event).
    virtual void reset(std::byte* state) const = 0;
    // Appends an event; returns the criteria that are true or may still become true.
    virtual uint64_t push(std::byte* state, const PathEvent& e) const = 0;
    // The criteria the whole path matches: the prefix `state`, then `suffix`, then its end.
    // `state` is not changed; `scratch` (stateBytes()) is overwritten.
    virtual uint64_t matches(const std::byte* state, std::span<const PathEvent> suffix,
                             std::byte* scratch) const = 0;
    // The criteria some path ending in `suffix` (events in path order, the last one the
    // detector hit) could match, whatever came before: 0 means no photon can make the path
    // match, and the backward branch that found the suffix can stop. May over-approximate
    // (never drops a criterion that could match). Thread-safe.
    virtual uint64_t suffixMayMatch(std::span<const PathEvent> suffix) const = 0;
};

}  // namespace veil
