#pragma once
// The scene as a run sees it, as text for a run's fingerprint (tracer/runtime/fingerprint.h):
// every object, the bounds, the optical properties and their assignment, and the sources,
// with full precision. Render and trace checkpoints add their own options to it.

#include <ostream>

namespace veil {

struct TransportView;

// Writes the text to `os` (its precision set to 17 digits).
void putSceneFingerprint(std::ostream& os, const TransportView& ts);

}  // namespace veil
