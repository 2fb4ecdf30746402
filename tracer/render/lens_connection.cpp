#include "tracer/render/lens_connection.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <variant>

#include "tracer/runtime/rng.h"
#include "tracer/surfaces/media.h"

namespace veil {

namespace {

constexpr uint64_t kPilotSeed = 0x6c656e73636f6e6eULL;  // the pilot's own stream key
constexpr int kMaxChain = LensConnector::kMaxSteps;     // bits of a chains() mask
constexpr int kNewtonIterations = 8;
constexpr int kLineSearchHalvings = 4;
constexpr double kWidestDeg = 80.0;      // a cone's parameter scale: tan of at most this
constexpr double kNarrowConeDeg = 20.0;  // an emitting area's cone that counts as a beam's
// The pilot's choice between a narrow-coned area's two parametrizations, per chain and object:
// at up to kChoicePoints of its photons' hits there, kChoiceDraws draws each.
constexpr size_t kChoicePoints = 16;
constexpr int kChoiceDraws = 4;

const Beam* beamOf(const Source& s) {
    if (const auto* c = std::get_if<CollimatedSource>(&s.shape())) return &c->beam;
    if (const auto* c = std::get_if<SunSource>(&s.shape())) return &c->beam;
    return nullptr;
}
const PointSource* pointOf(const Source& s) { return std::get_if<PointSource>(&s.shape()); }
const AreaEmitter* areaOf(const Source& s) {
    if (const auto* w = std::get_if<WindowSource>(&s.shape())) return &w->area;
    if (const auto* l = std::get_if<LambertianSource>(&s.shape())) return &l->area;
    return nullptr;
}

// Two unit vectors that make (b1, b2, e) orthonormal.
void basisAround(const Vec3& e, Vec3& b1, Vec3& b2) {
    const Vec3 a = std::abs(e.x) < 0.9 ? Vec3(1.0, 0.0, 0.0) : Vec3(0.0, 1.0, 0.0);
    b1 = glm::normalize(glm::cross(e, a));
    b2 = glm::cross(e, b1);
}

// The child of an interaction that continues the designed path (its event, not a scatter), or
// -1 when there is none (past the critical angle, an absorber).
int designedChild(const Interaction& in, EventType want) {
    for (int c = 0; c < in.count; ++c)
        if (!in.children[c].scatter && in.children[c].event == want) return c;
    return -1;
}

double largest(const Vec3& p) {
    return std::max({1.0, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
}

}  // namespace

// The chain as one evaluation leaves it: the ray after its last crossing, the medium it
// travels in, the transmittance of the crossings and the media between them.
struct LensConnector::Chain {
    Ray end;
    int medium = 0;
    int lastObject = -1, lastPrimitive = -1;
    double transmit = 1.0;
};

// The ghost routes the pilot met: a node per route prefix after the first reflection, its
// parent's key (a designed k, or kGhostBase + the parent node), and the light each brought to
// a scattering object.
struct LensConnector::GhostPilot {
    struct Node {
        int parent = 0, object = -1;
        EventType event = EventType::Refract;
        int lastStep = 0;
    };
    std::vector<Node> nodes;
    std::map<uint64_t, int> children;  // nodeCode(parent, object, event) -> node
    // (source * objects + object, node) -> light
    std::map<std::pair<size_t, int>, double> light;
    int child(int parent, int object, EventType event, int step) {
        const uint64_t code = nodeCode(parent, object, event);
        const auto it = children.find(code);
        if (it != children.end()) return it->second;
        const int key = kGhostBase + static_cast<int>(nodes.size());
        nodes.push_back({parent, object, event, step});
        children.emplace(code, key);
        return key;
    }
};

LensConnector::LensConnector(const TransportView& ts, bool ghostRoutes)
    : ts_(&ts), designed_(*ts.scene), objects_(ts.scene->objects().size()) {
    chains_.assign(ts.sources.size() * objects_, 0);
    other_.assign(ts.sources.size() * objects_, 0);
    for (const Source& src : ts.sources) params_.push_back(parametrize(src));
    if (designed_.steps() == 0) return;
    const Scene& scene = *ts.scene;
    // The pilot's first hits per chain, where the parametrizations are compared:
    // [source * objects + object] -> (steps, point).
    std::vector<std::vector<std::pair<int, Vec3>>> hits(ts.sources.size() * objects_);
    // The pilot's light per chain's object, for the ghost routes' share: [source * objects +
    // object], the designed chains'; (source * objects + object, provisional node) -> light,
    // the ghost routes'.
    std::vector<double> chainedLight(ts.sources.size() * objects_, 0.0);
    GhostPilot ghostPilot;

    for (size_t s = 0; s < ts.sources.size(); ++s) {
        const Source& src = ts.sources[s];
        for (uint64_t i = 0; i < kPilotPhotons; ++i) {
            CounterRng rng(kPilotSeed, s * kPilotPhotons + i);
            const EmittedRay e = src.emit(rng, kPilotPhotons);
            if (!(e.flux > 0.0)) continue;
            Ray ray = e.ray;
            int medium = 0, startObject = -1, startPrimitive = -1;
            double flux = e.flux;
            for (int step = 0;; ++step) {
                const auto hit =
                    scene.closestHit(ray, kInfinity, startObject, startPrimitive, medium);
                if (!hit || ts.detectorOfObject[hit->object] >= 0) break;
                flux *= std::exp(-ts.media->absorptionPerMm(medium, e.wavelength) * hit->t);
                const OpticalProperty& prop = ts.properties[ts.propertyOfObject[hit->object]];
                if (step >= 1 && step <= kMaxChain && prop.hasScatter()) {
                    const size_t at = s * objects_ + static_cast<size_t>(hit->object);
                    chains_[at] |= uint64_t{1} << (step - 1);
                    chainedLight[at] += flux;
                    any_ = true;
                    if (params_[s].count > 1 &&
                        std::count_if(hits[at].begin(), hits[at].end(), [&](const auto& h) {
                            return h.first == step;
                        }) < static_cast<std::ptrdiff_t>(kChoicePoints))
                        hits[at].emplace_back(step, hit->point);
                }
                if (step >= designed_.steps() || hit->object != designed_.objectOfStep(step)) break;
                const Interaction in =
                    interact(ts, *hit, ray.direction, e.wavelength, e.wavelengthNm);
                if (ghostRoutes && i < kGhostPilotPhotons &&
                    designed_.eventOfStep(step) == EventType::Refract) {
                    const int r = designedChild(in, EventType::FresnelReflect);
                    if (r >= 0)
                        walkGhosts(ghostPilot, s, *hit, in.children[r], step,
                                   flux * in.children[r].share *
                                       (static_cast<double>(kPilotPhotons) / kGhostPilotPhotons),
                                   e.wavelength, e.wavelengthNm);
                }
                const int c = designedChild(in, designed_.eventOfStep(step));
                if (c < 0) break;
                flux *= in.children[c].share;
                ray = {hit->point, in.children[c].direction};
                medium = in.children[c].medium;
                startObject = hit->object;
                startPrimitive = hit->primitive;
            }
        }
    }
    findGhostChains(ghostPilot, chainedLight);
    seeds_.assign(ts.sources.size(), {});
    for (size_t s = 0; s < ts.sources.size(); ++s) {
        uint64_t all = 0;
        bool ghosts = false;
        for (size_t o = 0; o < objects_; ++o) {
            all |= chains_[s * objects_ + o];
            ghosts = ghosts || !ghostChains(s, static_cast<int>(o)).empty();
        }
        if (all == 0 && !ghosts) continue;
        seeds_[s].resize(static_cast<size_t>(params_[s].count));
        for (int m = 0; m < params_[s].count; ++m) {
            std::vector<std::vector<SeedGrid>>& grids = seeds_[s][static_cast<size_t>(m)];
            grids.resize(static_cast<size_t>(64 - std::countl_zero(all)));
            const std::vector<Vec3> fixes = seedFixes(s, m);
            for (uint64_t bits = all; bits != 0; bits &= bits - 1) {
                const int steps = std::countr_zero(bits) + 1;
                for (const Vec3& f : fixes)
                    grids[static_cast<size_t>(steps - 1)].push_back(buildSeeds(s, m, steps, f));
            }
            // The ghost chains' (the source's own parametrization only).
            if (m != 0) continue;
            for (size_t o = 0; o < objects_; ++o)
                for (const int key : ghostChains(s, static_cast<int>(o))) {
                    const size_t slot = slotOf(key);
                    if (grids.size() <= slot) grids.resize(slot + 1);
                    if (!grids[slot].empty()) continue;
                    for (const Vec3& f : fixes) grids[slot].push_back(buildSeeds(s, m, key, f));
                }
        }
    }
    // Each chain's parametrization: the one whose light at the pilot's points has the smaller
    // second moment (both estimate the same light; the other one's draws mostly miss there),
    // from the same draws of the two uniforms. Kept the source's own where neither finds any.
    for (size_t s = 0; s < ts.sources.size(); ++s) {
        if (params_[s].count < 2) continue;
        const double firstNm = ts.sources[s].spectrum().lines().front().nm;
        for (size_t o = 0; o < objects_; ++o) {
            const size_t at = s * objects_ + o;
            for (uint64_t bits = chains_[at]; bits != 0; bits &= bits - 1) {
                const int steps = std::countr_zero(bits) + 1;
                double moment[2] = {0.0, 0.0};
                int found[2] = {0, 0};
                uint64_t draw = 0;
                for (const auto& [k, point] : hits[at]) {
                    if (k != steps) continue;
                    for (int d = 0; d < kChoiceDraws; ++d, ++draw) {
                        CounterRng rng(kPilotSeed ^ 0x63686f6963650000ULL,
                                       (at * 64 + static_cast<uint64_t>(steps - 1)) * 4096 + draw);
                        const double u1 = rng.uniform(), u2 = rng.uniform();
                        for (int m = 0; m < 2; ++m) {
                            Work work;
                            const auto light = connectAs(m, s, 0, firstNm, steps, point,
                                                         static_cast<int>(o), u1, u2, work);
                            if (!light) continue;
                            ++found[m];
                            moment[m] += light->value * light->value;
                        }
                    }
                }
                if (found[1] > 0 && (found[0] == 0 || moment[1] < moment[0]))
                    other_[at] |= uint64_t{1} << (steps - 1);
            }
        }
    }
}

void LensConnector::walkGhosts(GhostPilot& pilot, size_t s, const SceneHit& hit,
                               const InteractionChild& reflected, int step, double flux, int line,
                               double wavelengthNm) const {
    const TransportView& ts = *ts_;
    struct Branch {
        Ray ray;
        int medium = 0, startObject = -1, startPrimitive = -1;
        double flux = 0.0;
        int key = 0, reflections = 0;
    };
    std::vector<Branch> stack;
    stack.push_back({{hit.point, reflected.direction},
                     reflected.medium,
                     hit.object,
                     hit.primitive,
                     flux,
                     pilot.child(step, hit.object, EventType::FresnelReflect, step),
                     1});
    // A route crosses each face at most a few times: light that has not left the lens after
    // this many crossings is a loop's (total internal reflection along a ring).
    const int longest = 4 * designed_.steps() + 8;
    while (!stack.empty()) {
        Branch b = stack.back();
        stack.pop_back();
        for (int crossings = 0; crossings < longest && b.flux > 0.0; ++crossings) {
            const auto h =
                ts.scene->closestHit(b.ray, kInfinity, b.startObject, b.startPrimitive, b.medium);
            if (!h || ts.detectorOfObject[h->object] >= 0) break;
            b.flux *= std::exp(-ts.media->absorptionPerMm(b.medium, line) * h->t);
            if (ts.properties[ts.propertyOfObject[h->object]].hasScatter())
                pilot.light[{s * objects_ + static_cast<size_t>(h->object), b.key}] += b.flux;
            const int at = designed_.stepOf(h->object);
            if (at == DesignedPath::kOff) break;
            const Interaction in = interact(ts, *h, b.ray.direction, line, wavelengthNm);
            const EventType want = designed_.eventOfStep(at);
            if (b.reflections < kMaxGhostReflections && want == EventType::Refract) {
                const int r = designedChild(in, EventType::FresnelReflect);
                if (r >= 0 && in.children[r].share > 0.0)
                    stack.push_back({{h->point, in.children[r].direction},
                                     in.children[r].medium,
                                     h->object,
                                     h->primitive,
                                     b.flux * in.children[r].share,
                                     pilot.child(b.key, h->object, EventType::FresnelReflect, at),
                                     b.reflections + 1});
            }
            const int c = designedChild(in, want);
            if (c < 0) break;
            b.flux *= in.children[c].share;
            b.key = pilot.child(b.key, h->object, want, at);
            b.ray = {h->point, in.children[c].direction};
            b.medium = in.children[c].medium;
            b.startObject = h->object;
            b.startPrimitive = h->primitive;
        }
    }
}

void LensConnector::findGhostChains(GhostPilot& pilot, const std::vector<double>& chainedLight) {
    if (pilot.light.empty()) return;
    // Per (source, object): its ghost routes by light, most first.
    std::map<size_t, std::vector<std::pair<double, int>>> byObject;
    std::vector<double> ghostLight(chainedLight.size(), 0.0);
    for (const auto& [at, light] : pilot.light) {
        byObject[at.first].emplace_back(light, at.second);
        ghostLight[at.first] += light;
    }
    // Per source: all the light the pilot brought to scattering objects by the chains.
    std::vector<double> sourceLight(ts_->sources.size(), 0.0);
    for (size_t at = 0; at < chainedLight.size(); ++at)
        sourceLight[at / objects_] += chainedLight[at] + ghostLight[at];
    std::vector<std::pair<size_t, int>> kept;  // (source * objects + object, provisional key)
    for (auto& [at, routes] : byObject) {
        std::sort(routes.begin(), routes.end(), [](const auto& x, const auto& y) {
            return x.first > y.first || (x.first == y.first && x.second < y.second);
        });
        const double total = chainedLight[at] + ghostLight[at];
        for (size_t i = 0; i < routes.size() && i < kGhostChains; ++i)
            if (routes[i].first >= kGhostShare * total &&
                routes[i].first >= kGhostFloor * sourceLight[at / objects_])
                kept.emplace_back(at, routes[i].second);
    }
    if (kept.empty()) return;
    // The nodes on the way to a kept route, in the pilot's order (a parent before its child).
    std::vector<bool> used(pilot.nodes.size(), false);
    for (const auto& [at, key] : kept)
        for (int k = key; k >= kGhostBase;
             k = pilot.nodes[static_cast<size_t>(k - kGhostBase)].parent)
            used[static_cast<size_t>(k - kGhostBase)] = true;
    std::vector<int> renamed(pilot.nodes.size(), DesignedPath::kOff);
    for (size_t i = 0; i < pilot.nodes.size(); ++i) {
        if (!used[i]) continue;
        const GhostPilot::Node& n = pilot.nodes[i];
        const int key = kGhostBase + static_cast<int>(ghostLastSteps_.size());
        renamed[i] = key;
        const int parent =
            n.parent >= kGhostBase ? renamed[static_cast<size_t>(n.parent - kGhostBase)] : n.parent;
        std::vector<std::pair<int, EventType>> route;
        if (parent >= kGhostBase) {
            route = ghostRoutes_[static_cast<size_t>(parent - kGhostBase)];
        } else {
            for (int k = 0; k < parent; ++k)
                route.emplace_back(designed_.objectOfStep(k), designed_.eventOfStep(k));
        }
        route.emplace_back(n.object, n.event);
        ghostLastSteps_.push_back(n.lastStep);
        ghostRoutes_.push_back(std::move(route));
        ghostChildren_.emplace_back(nodeCode(parent, n.object, n.event), key);
    }
    std::sort(ghostChildren_.begin(), ghostChildren_.end());
    ghostChains_.assign(chainedLight.size(), {});
    for (const auto& [at, key] : kept)
        ghostChains_[at].push_back(renamed[static_cast<size_t>(key - kGhostBase)]);
    for (std::vector<int>& keys : ghostChains_) std::sort(keys.begin(), keys.end());
    any_ = true;
}

LensConnector::ParameterSets LensConnector::parametrize(const Source& src) {
    ParameterSets sets;
    Parameters& p = sets.set[0];
    if (const Beam* beam = beamOf(src)) {
        p.movesOrigin = true;
        p.center = beam->startCenterMm;
        p.axis = beam->direction;
        p.u = beam->axisU;
        p.v = beam->axisV;
        p.scale = std::max(beam->radiusMm, 1e-6);
        return sets;
    }
    if (const PointSource* pt = pointOf(src)) {
        p.center = pt->positionMm;
        p.axis = pt->axis;
        p.u = pt->axisU;
        p.v = pt->axisV;
        p.scale = std::tan(std::min(pt->halfAngleRad, kWidestDeg * std::numbers::pi / 180.0));
        return sets;
    }
    const AreaEmitter& area = *areaOf(src);
    p.center = area.frame.translation;
    p.axis = area.frame.toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    p.u = area.frame.toGlobalDirection(Vec3(1.0, 0.0, 0.0));
    p.v = area.frame.toGlobalDirection(Vec3(0.0, 1.0, 0.0));
    // A narrow cone (a window's few degrees) is a beam with a spread: its direction is drawn
    // and the point on the area solved for, so that every solution lies in the cone. A wide
    // one draws the point and solves for the direction, which a small emitter needs.
    // A narrow cone also has the wide one's way (the header comment, step 1).
    const double onArea = std::max(area.shape == AreaEmitter::Shape::Disk
                                       ? area.radiusMm
                                       : 0.5 * std::hypot(area.sizeMm.x, area.sizeMm.y),
                                   1e-6);
    const double ofCone =
        std::tan(std::min(area.coneHalfAngleRad, kWidestDeg * std::numbers::pi / 180.0));
    p.movesOrigin = area.coneHalfAngleRad < kNarrowConeDeg * std::numbers::pi / 180.0;
    p.scale = p.movesOrigin ? onArea : ofCone;
    if (p.movesOrigin) {
        sets.set[1] = p;
        sets.set[1].movesOrigin = false;
        sets.set[1].scale = ofCone;
        sets.count = 2;
    }
    return sets;
}

bool LensConnector::reaches(const Ray& from, int fromObject, int fromPrimitive, int medium,
                            const Vec3& point, int object) const {
    const double toPoint = glm::dot(point - from.origin, from.direction);
    if (!(toPoint > 0.0)) return false;
    const double tol = 1e-5 * largest(point) + 1e-6 * toPoint;
    if (object < 0)  // a point in the open: nothing before it
        return !ts_->scene->closestHit(from, toPoint - tol, fromObject, fromPrimitive, medium);
    const auto hit = ts_->scene->closestHit(from, kInfinity, fromObject, fromPrimitive, medium);
    return hit && hit->object == object && std::abs(hit->t - toPoint) <= tol;
}

bool LensConnector::inView(size_t s, int steps, const Vec3& fixed, const Vec3& point, int object,
                           Work& work) const {
    return inViewAs(parametrization(s, object, steps), s, steps, fixed, point, object, work);
}

bool LensConnector::inViewAs(int m, size_t s, int steps, const Vec3& fixed, const Vec3& point,
                             int object, Work& work) const {
    double a = 0.0, b = 0.0;
    size_t node = 0;
    const SeedGrid* g = seed(s, m, steps, fixed, point, a, b, &node);
    if (!g) return false;
    // The node's last segment turned toward the point, from where it left the last face.
    const Ray& end = g->ends[node];
    const Vec3 to = point - end.origin;
    const double distance = glm::length(to);
    if (!(distance > 0.0)) return false;
    ++work.rays;
    return reaches({end.origin, to / distance}, g->lastObjects[node], g->lastPrimitives[node],
                   g->media[node], point, object);
}

std::vector<Vec3> LensConnector::seedFixes(size_t s, int m) const {
    const Parameters& pm = params_[s].set[m];
    const Source& src = ts_->sources[s];
    const AreaEmitter* area = areaOf(src);
    if (!area) return {pm.movesOrigin ? pm.axis : pm.center};
    std::vector<Vec3> out;
    for (int i = 0; i < kSeedFixes; ++i)
        for (int j = 0; j < kSeedFixes; ++j) {
            const double x = 2.0 * (i + 0.5) / kSeedFixes - 1.0,
                         y = 2.0 * (j + 0.5) / kSeedFixes - 1.0;
            if (pm.movesOrigin) {
                // Directions over the cone.
                const double t = std::tan(area->coneHalfAngleRad);
                if (x * x + y * y > 1.0) continue;
                out.push_back(glm::normalize(pm.axis + t * (x * pm.u + y * pm.v)));
            } else if (area->shape == AreaEmitter::Shape::Disk) {
                if (x * x + y * y > 1.0) continue;
                out.push_back(pm.center + area->radiusMm * (x * pm.u + y * pm.v));
            } else {
                out.push_back(pm.center +
                              0.5 * (x * area->sizeMm.x * pm.u + y * area->sizeMm.y * pm.v));
            }
        }
    return out;
}

LensConnector::SeedGrid LensConnector::buildSeeds(size_t s, int m, int steps,
                                                  const Vec3& fixed) const {
    const Parameters& pm = params_[s].set[m];
    SeedGrid g;
    g.fixed = fixed;
    // At the first line (model wavelength 0): a seed needs no more.
    const double firstNm = ts_->sources[s].spectrum().lines().front().nm;
    Work work;
    for (int i = 0; i < kSeedGrid; ++i)
        for (int j = 0; j < kSeedGrid; ++j) {
            const double a = pm.scale * (2.0 * (i + 0.5) / kSeedGrid - 1.0);
            const double b = pm.scale * (2.0 * (j + 0.5) / kSeedGrid - 1.0);
            Chain c;
            if (!trace(entryRay(s, m, fixed, a, b), steps, 0, firstNm, c, work, nullptr)) continue;
            g.ends.push_back(c.end);
            g.params.emplace_back(a, b);
            g.lastObjects.push_back(c.lastObject);
            g.lastPrimitives.push_back(c.lastPrimitive);
            g.media.push_back(c.medium);
        }
    return g;
}

const LensConnector::SeedGrid* LensConnector::seed(size_t s, int m, int steps, const Vec3& fixed,
                                                   const Vec3& point, double& a, double& b,
                                                   size_t* node) const {
    if (seeds_[s].size() <= static_cast<size_t>(m)) return nullptr;
    const std::vector<std::vector<SeedGrid>>& bySteps = seeds_[s][static_cast<size_t>(m)];
    if (bySteps.size() <= slotOf(steps)) return nullptr;
    const std::vector<SeedGrid>& grids = bySteps[slotOf(steps)];
    if (grids.empty()) return nullptr;
    const SeedGrid* g = &grids.front();
    for (const SeedGrid& x : grids)
        if (glm::length(x.fixed - fixed) < glm::length(g->fixed - fixed)) g = &x;
    double best = kInfinity;
    for (size_t n = 0; n < g->ends.size(); ++n) {
        const Vec3 d = point - g->ends[n].origin;
        const double along = glm::dot(d, g->ends[n].direction);
        if (!(along > 0.0)) continue;
        const double miss = glm::length(d - g->ends[n].direction * along);
        if (miss < best) {
            best = miss;
            a = g->params[n].x;
            b = g->params[n].y;
            if (node) *node = n;
        }
    }
    return best < kInfinity ? g : nullptr;
}

Ray LensConnector::entryRay(size_t s, int m, const Vec3& fixed, double a, double b) const {
    const Parameters& p = params_[s].set[m];
    if (p.movesOrigin) return {p.center + a * p.u + b * p.v, fixed};
    return {fixed, glm::normalize(p.axis + a * p.u + b * p.v)};
}

void LensConnector::parametersOf(size_t s, int m, const Ray& entry, double& a, double& b) const {
    const Parameters& p = params_[s].set[m];
    if (p.movesOrigin) {
        const Vec3 d = entry.origin - p.center;
        a = glm::dot(d, p.u);
        b = glm::dot(d, p.v);
        return;
    }
    const double along = glm::dot(entry.direction, p.axis);
    const Vec3 t = along > 0.0 ? entry.direction / along - p.axis : Vec3(0.0);
    a = glm::dot(t, p.u);
    b = glm::dot(t, p.v);
}

Vec3 LensConnector::fixedIn(const Parameters& p, const Ray& entry) {
    return p.movesOrigin ? entry.direction : entry.origin;
}

Vec3 LensConnector::fixedOf(size_t s, int object, int steps, const Ray& entry) const {
    return fixedIn(params_[s].set[parametrization(s, object, steps)], entry);
}

double LensConnector::fluxPerParameter(size_t s, int m, int line, const Ray& entry) const {
    const Parameters& pm = params_[s].set[m];
    const Source& src = ts_->sources[s];
    const double emitted = src.emitted(entry.origin, entry.direction, line);
    if (!(emitted > 0.0)) return 0.0;
    const double c = glm::dot(entry.direction, pm.axis);
    if (!(c > 0.0)) return 0.0;
    if (std::holds_alternative<SunSource>(src.shape()))
        // Radiance L = Phi / (A Omega cos): per unit of the start plane and per direction
        // drawn uniformly over the disk (pdf 1 / Omega), L cos Omega.
        return emitted * c * src.emittingSolidAngleSr();
    if (std::holds_alternative<CollimatedSource>(src.shape()))
        return emitted;  // E per unit of the start plane
    if (pointOf(src))
        // Directions per unit of the tangent plane: dOmega = da db / (1 + a^2 + b^2)^(3/2) =
        // cos^3 da db; intensity I gives I cos^3.
        return emitted * c * c * c;
    if (pm.movesOrigin) {
        // Per unit of the area, the direction drawn by the cosine law within the cone (pdf
        // cos / (pi sin^2 cone)): L cos / pdf = L pi sin^2 cone.
        const double sinCone = std::sin(areaOf(src)->coneHalfAngleRad);
        return emitted * std::numbers::pi * sinCone * sinCone;
    }
    // The point drawn uniformly on the area (pdf 1 / A), the direction per unit of the
    // tangent plane: L cos A cos^3.
    return emitted * src.emittingAreaMm2() * c * c * c * c;
}

bool LensConnector::cross(const SceneHit& hit, EventType want, int line, double wavelengthNm,
                          Ray& ray, int& medium, double& transmit,
                          std::vector<PathEvent>* events) const {
    const Interaction in = interact(*ts_, hit, ray.direction, line, wavelengthNm);
    const int c = designedChild(in, want);
    if (c < 0) return false;
    const InteractionChild& child = in.children[c];
    transmit *= child.share;
    if (events) events->push_back(pathEvent(want, hit.object, hit.primitive, medium, child.medium));
    ray = {hit.point, child.direction};
    medium = child.medium;
    return true;
}

bool LensConnector::trace(const Ray& entry, int steps, int line, double wavelengthNm, Chain& out,
                          Work& work, std::vector<PathEvent>* events, Crossing crossing) const {
    const TransportView& ts = *ts_;
    Ray ray = entry;
    int medium = 0, startObject = -1, startPrimitive = -1;
    double transmit = 1.0;
    if (events) events->clear();
    const bool ghost = steps >= kGhostBase;
    const int n = lengthOf(steps);
    for (int i = 0; i < n; ++i) {
        const auto [object, want] =
            ghost ? routeOf(steps)[static_cast<size_t>(i)]
                  : std::pair<int, EventType>(designed_.objectOfStep(i), designed_.eventOfStep(i));
        const bool alone = crossing == Crossing::Faces &&
                           std::holds_alternative<FaceGeometry>(ts.scene->object(object).geometry);
        const auto hit =
            alone ? ts.scene->hitOnFace(ray, object, startObject)
                  : ts.scene->closestHit(ray, kInfinity, startObject, startPrimitive, medium);
        ++work.rays;
        if (!hit || hit->object != object) return false;
        const double alpha = ts.media->absorptionPerMm(medium, line);
        if (alpha > 0.0) transmit *= std::exp(-alpha * hit->t);
        if (!cross(*hit, want, line, wavelengthNm, ray, medium, transmit, events)) return false;
        startObject = hit->object;
        startPrimitive = hit->primitive;
    }
    out.end = ray;
    out.medium = medium;
    out.lastObject = startObject;
    out.lastPrimitive = startPrimitive;
    out.transmit = transmit;
    return true;
}

std::optional<LensConnector::Onward> LensConnector::onward(
    const Ray& start, int startObject, int startPrimitive, int medium, int fromStep, int line,
    double wavelengthNm, int detectorObject, Work& work, std::vector<PathEvent>* events) const {
    const TransportView& ts = *ts_;
    Onward out;
    Ray ray = start;
    if (events) events->clear();
    for (int i = fromStep;; ++i) {
        const auto hit = ts.scene->closestHit(ray, kInfinity, startObject, startPrimitive, medium);
        ++work.rays;
        const bool last = i >= designed_.steps();
        if (!hit || hit->object != (last ? detectorObject : designed_.objectOfStep(i)))
            return std::nullopt;
        if (i == fromStep) {
            out.firstPoint = hit->point;
            out.firstNormal = hit->normal;
            out.firstPrimitive = hit->primitive;
        }
        const double alpha = ts.media->absorptionPerMm(medium, line);
        if (alpha > 0.0) out.transmit *= std::exp(-alpha * hit->t);
        if (last) {
            if (events)
                events->push_back(
                    pathEvent(EventType::DetectorHit, hit->object, hit->primitive, medium, medium));
            out.detectorHit = *hit;
            out.medium = medium;
            return out;
        }
        if (!cross(*hit, designed_.eventOfStep(i), line, wavelengthNm, ray, medium, out.transmit,
                   events))
            return std::nullopt;
        startObject = hit->object;
        startPrimitive = hit->primitive;
    }
}

namespace {

// Where a chain's last segment (o, e) crosses the plane through p perpendicular to n, as
// coordinates along (b1, b2) relative to p; false when it runs parallel to the plane.
bool crossingAt(const Ray& end, const Vec3& p, const Vec3& n, const Vec3& b1, const Vec3& b2,
                Vec2& x) {
    const double along = glm::dot(end.direction, n);
    if (!(along > 1e-9)) return false;
    const Vec3 q = end.origin + end.direction * (glm::dot(p - end.origin, n) / along) - p;
    x = Vec2(glm::dot(q, b1), glm::dot(q, b2));
    return true;
}

// The distance from p to the line of a chain's last segment.
double missOf(const Ray& end, const Vec3& p) {
    const Vec3 d = p - end.origin;
    return glm::length(d - end.direction * glm::dot(d, end.direction));
}

}  // namespace

bool LensConnector::solve(size_t s, int m, int line, double wavelengthNm, int steps,
                          const Vec3& point, const Vec3& fixed, double& a, double& b,
                          Work& work) const {
    const Parameters& pm = params_[s].set[m];
    const double scale = pm.scale;
    const double tol = 1e-9 * largest(point);
    // The start: the seed grid's node whose last segment passes nearest the point; without
    // one (no node of the grid follows the chain), the straight line from the source to the
    // point, drawn toward the axis until its chain traces.
    Chain c;
    bool started = seed(s, m, steps, fixed, point, a, b) != nullptr &&
                   trace(entryRay(s, m, fixed, a, b), steps, line, wavelengthNm, c, work, nullptr,
                         Crossing::Faces);
    if (!started) {
        const Ray straight = pm.movesOrigin
                                 ? Ray{point - fixed * (glm::dot(point - pm.center, pm.axis) /
                                                        glm::dot(fixed, pm.axis)),
                                       fixed}
                                 : Ray{fixed, glm::normalize(point - fixed)};
        double a0 = 0.0, b0 = 0.0;
        parametersOf(s, m, straight, a0, b0);
        for (const double f : {1.0, 0.75, 0.5, 0.25, 0.0}) {
            a = a0 * f;
            b = b0 * f;
            if (trace(entryRay(s, m, fixed, a, b), steps, line, wavelengthNm, c, work, nullptr,
                      Crossing::Faces)) {
                started = true;
                break;
            }
        }
    }
    if (!started) return false;
    double miss = missOf(c.end, point);
    const double h = 1e-7 * scale;
    for (int it = 0; it < kNewtonIterations; ++it) {
        if (miss <= tol) return true;
        // The residual and its Jacobian on the plane through the point perpendicular to the
        // current last segment.
        const Vec3 n = c.end.direction;
        Vec3 b1, b2;
        basisAround(n, b1, b2);
        Vec2 r;
        if (!crossingAt(c.end, point, n, b1, b2, r)) return false;
        Vec2 col[2];
        for (int k = 0; k < 2; ++k) {
            Chain ck;
            double step = h;
            bool ok = false;
            for (const double sign : {1.0, -1.0}) {
                step = sign * h;
                const double ak = a + (k == 0 ? step : 0.0), bk = b + (k == 1 ? step : 0.0);
                if (trace(entryRay(s, m, fixed, ak, bk), steps, line, wavelengthNm, ck, work,
                          nullptr, Crossing::Faces) &&
                    crossingAt(ck.end, point, n, b1, b2, col[k])) {
                    ok = true;
                    break;
                }
            }
            if (!ok) return false;
            col[k] = (col[k] - r) / step;
        }
        const double det = col[0].x * col[1].y - col[1].x * col[0].y;
        if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
        const double da = -(col[1].y * r.x - col[1].x * r.y) / det;
        const double db = -(-col[0].y * r.x + col[0].x * r.y) / det;
        // Backtracking: the full step, or the largest half of it that gets closer.
        bool moved = false;
        double lambda = 1.0;
        for (int k = 0; k < kLineSearchHalvings; ++k, lambda *= 0.5) {
            Chain trial;
            const double at = a + lambda * da, bt = b + lambda * db;
            if (!trace(entryRay(s, m, fixed, at, bt), steps, line, wavelengthNm, trial, work,
                       nullptr, Crossing::Faces))
                continue;
            const double trialMiss = missOf(trial.end, point);
            if (trialMiss < miss) {
                a = at;
                b = bt;
                c = trial;
                miss = trialMiss;
                moved = true;
                break;
            }
        }
        if (!moved) return false;
    }
    return miss <= tol;
}

std::optional<LensConnector::Light> LensConnector::connectAs(int m, size_t s, int line,
                                                             double wavelengthNm, int steps,
                                                             const Vec3& point, int object,
                                                             double u1, double u2, Work& work,
                                                             std::vector<PathEvent>* events) const {
    const Source& src = ts_->sources[s];
    if (!validKey(steps) || m < 0 || m >= params_[s].count) return std::nullopt;
    const Parameters& pm = params_[s].set[m];
    // What the solver keeps (fluxPerParameter has the pdfs): a beam's direction, drawn
    // uniformly over the Sun's disk; a narrow cone's direction, drawn by the cosine law; a
    // point's position; a point drawn uniformly on a wide-coned area.
    Vec3 fixed = pm.movesOrigin ? pm.axis : pm.center;
    const AreaEmitter* area = areaOf(src);
    const Beam* beam = beamOf(src);
    if (area && !pm.movesOrigin) {
        Vec3 local(0.0);
        if (area->shape == AreaEmitter::Shape::Disk) {
            const double rho = area->radiusMm * std::sqrt(u1), phi = 2.0 * std::numbers::pi * u2;
            local = Vec3(rho * std::cos(phi), rho * std::sin(phi), 0.0);
        } else {
            local = Vec3((u1 - 0.5) * area->sizeMm.x, (u2 - 0.5) * area->sizeMm.y, 0.0);
        }
        fixed = area->frame.toGlobalPoint(local);
    } else if ((beam && beam->halfAngleRad > 0.0) || area) {
        double cosTheta = 1.0, sinTheta = 0.0;
        if (beam) {
            // Uniform over the solid angle of the disk.
            cosTheta = 1.0 - u1 * (1.0 - std::cos(beam->halfAngleRad));
            sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
        } else {
            // The cosine law within the cone: sin^2 uniform up to sin^2 cone.
            sinTheta = std::sin(area->coneHalfAngleRad) * std::sqrt(u1);
            cosTheta = std::sqrt(std::max(0.0, 1.0 - sinTheta * sinTheta));
        }
        const double phi = 2.0 * std::numbers::pi * u2;
        fixed = glm::normalize(cosTheta * pm.axis +
                               sinTheta * (std::cos(phi) * pm.u + std::sin(phi) * pm.v));
    }
    return connectWith(s, m, line, wavelengthNm, steps, point, object, fixed, work, events);
}

std::optional<LensConnector::Light> LensConnector::connectWith(
    size_t s, int m, int line, double wavelengthNm, int steps, const Vec3& point, int object,
    const Vec3& fixed, Work& work, std::vector<PathEvent>* events) const {
    if (!inViewAs(m, s, steps, fixed, point, object, work)) return std::nullopt;
    double a = 0.0, b = 0.0;
    if (!solve(s, m, line, wavelengthNm, steps, point, fixed, a, b, work)) return std::nullopt;
    const Ray entry = entryRay(s, m, fixed, a, b);
    Chain c;
    if (!trace(entry, steps, line, wavelengthNm, c, work, events)) return std::nullopt;
    const double toPoint = glm::dot(point - c.end.origin, c.end.direction);
    if (!(toPoint > 0.0)) return std::nullopt;
    const double det = jacobian(s, m, line, wavelengthNm, steps, point, fixed, a, b, c, work);
    if (!(det > 0.0)) return std::nullopt;
    const double fu = fluxPerParameter(s, m, line, entry);
    if (!(fu > 0.0)) return std::nullopt;
    // Nothing between the last crossing and the point: the last segment, traced as the light
    // travels it, first meets the point's object at the point (within the rounding of a mesh's
    // single-precision hits; a ray traced back from the point can meet a neighbouring triangle
    // of its own mesh at once).
    ++work.rays;
    if (!reaches(c.end, c.lastObject, c.lastPrimitive, c.medium, point, object))
        return std::nullopt;
    const Vec3 back = -c.end.direction;
    const double alpha = ts_->media->absorptionPerMm(c.medium, line);
    Light out;
    out.toLight = back;
    out.distanceMm = toPoint;
    out.entry = entry;
    out.value = fu * c.transmit * (alpha > 0.0 ? std::exp(-alpha * toPoint) : 1.0) / det;
    if (!(out.value > 0.0) || !std::isfinite(out.value)) return std::nullopt;
    // The density of toLight: n^2 L is conserved along the chain, so the radiance arriving is
    // T L (n_point / n_source)^2 and value = that radiance over the density per steradian.
    const Source& src = ts_->sources[s];
    if (!pointOf(src) && !std::holds_alternative<CollimatedSource>(src.shape())) {
        const double n0 = ts_->media->index(0, line), n = ts_->media->index(c.medium, line);
        out.pdfSr =
            src.emitted(entry.origin, entry.direction, line) * (n * n) / (n0 * n0) * det / fu;
    }
    return out;
}

double LensConnector::jacobian(size_t s, int m, int line, double wavelengthNm, int steps,
                               const Vec3& point, const Vec3& fixed, double a, double b,
                               const Chain& at, Work& work) const {
    // Central differences on the plane through the point perpendicular to the ray; one-sided
    // where a neighbour leaves the chain (the rim of an aperture).
    const Vec3 n = at.end.direction;
    Vec3 b1, b2;
    basisAround(n, b1, b2);
    Vec2 r;
    if (!crossingAt(at.end, point, n, b1, b2, r)) return 0.0;
    const double h = 1e-5 * params_[s].set[m].scale;
    Vec2 col[2];
    for (int k = 0; k < 2; ++k) {
        Vec2 side[2];
        bool ok[2] = {false, false};
        for (int j = 0; j < 2; ++j) {
            const double step = j == 0 ? h : -h;
            Chain cj;
            const double aj = a + (k == 0 ? step : 0.0), bj = b + (k == 1 ? step : 0.0);
            ok[j] = trace(entryRay(s, m, fixed, aj, bj), steps, line, wavelengthNm, cj, work,
                          nullptr, Crossing::Faces) &&
                    crossingAt(cj.end, point, n, b1, b2, side[j]);
        }
        if (ok[0] && ok[1])
            col[k] = (side[0] - side[1]) / (2.0 * h);
        else if (ok[0])
            col[k] = (side[0] - r) / h;
        else if (ok[1])
            col[k] = (r - side[1]) / h;
        else
            return 0.0;
    }
    return std::abs(col[0].x * col[1].y - col[1].x * col[0].y);
}

bool LensConnector::finds(size_t s, int line, double wavelengthNm, int steps, const Vec3& point,
                          int object, const Ray& emitted, Work& work) const {
    return found(s, line, wavelengthNm, steps, point, object, emitted, work).has_value();
}

std::optional<LensConnector::Light> LensConnector::foundAs(int m, size_t s, int line,
                                                           double wavelengthNm, int steps,
                                                           const Vec3& point, int object,
                                                           const Ray& emitted, Work& work) const {
    if (!validKey(steps) || m < 0 || m >= params_[s].count) return std::nullopt;
    const Parameters& pm = params_[s].set[m];
    // Everything connect() does with this fixed half, then the same ray.
    auto light = connectWith(s, m, line, wavelengthNm, steps, point, object, fixedIn(pm, emitted),
                             work, nullptr);
    if (!light) return std::nullopt;
    double a = 0.0, b = 0.0, pa = 0.0, pb = 0.0;
    parametersOf(s, m, light->entry, a, b);
    parametersOf(s, m, emitted, pa, pb);
    if (!(std::hypot(a - pa, b - pb) <= 1e-6 * pm.scale)) return std::nullopt;
    return light;
}

}  // namespace veil
