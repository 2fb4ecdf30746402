#pragma once
// What path criteria may name in a prepared scene: objects (with aliases, resolved optical
// property and whether they are detectors), media and sources, indexed as in the path
// histories (analysis/criteria/criteria.h resolves names against this table).

#include "analysis/criteria/criteria.h"

namespace veil {

class Scene;
struct TransportView;

NameTable criterionNames(const Scene& scene, const TransportView& transport);

}  // namespace veil
