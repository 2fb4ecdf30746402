#pragma once
// Light connected through the lens (docs/render.md, "Light connected through the lens"): the
// light of a source that reaches a view point through the lens as designed, found exactly
// instead of gathered.
//
// A mount inside the barrel sees the Sun only through the elements in front of it. Photons
// find that light where they happen to land within a view point's gathering disk; a narrow
// lobe (a 5 degree Gaussian) then keeps only the few that also arrive along the one direction
// it sends toward the pixel. Here the path is solved instead. For a view point at p and a
// chain of the first k faces of the lens's designed path (tracer/render/designed_path.h):
//
//   1. the source's free half is drawn (a direction over the solar disk or, by the cosine
//      law, inside a window's narrow cone; a point on a wide-coned emitting area; a collimated
//      beam and a point source have none), and Newton's method on the other half (the point
//      on the beam's start plane or on the window, or the direction from a point) finds the
//      ray that crosses those k faces as designed (refracting at lens faces, reflecting at
//      mirrors, with their coatings, apertures and shapes) and then passes through p. Its
//      steps meet each face alone (Crossing::Faces, a sequential trace); the ray found is
//      then traced in the scene itself, every part in the way refusing it. It starts from
//      the nearest node of a seed grid of the chain traced once.
//      A narrow-coned area has both ways (parametrizations()): its direction drawn and its
//      point solved, which suits points near a pupil (few points of the window reach them,
//      from many directions), or its point drawn and its direction solved, which suits points
//      near an image of the window's far field (a flat beside the field lens: every point of
//      the window reaches it, from a few directions). The pilot picks one per chain and
//      object: the one whose light at the pilot's own points has the smaller second moment
//      (parametrization()).
//      The residual is where the last segment crosses the plane through p perpendicular to
//      it; the Jacobian comes from finite differences (forward while iterating, central for
//      the result);
//   2. the beam's density there follows from the Jacobian: the flux the source sends through
//      a parameter cell du arrives spread over |det J| du of that plane, so the irradiance at
//      p perpendicular to the ray is F_u T / |det J| (F_u the source's flux per unit of its
//      parameters: fluxPerParameter; T the transmittance of the k crossings and of the media
//      between them);
//   3. the last segment, traced forward from the k-th face, must first meet p's object at p
//      (reaches()).
//
// Ghost routes. Light that a bare face reflects back (a Fresnel ghost) lights parts as well:
// in the Sun example 98 % of what L5's ground flats scatter onto the sensor arrived after one
// or two such reflections. A chain may follow such a route instead of the designed path: the
// designed path to a face, the face's Fresnel reflection, the faces met after it crossed as
// their designed event (a lens face refracting, a mirror reflecting) and at most
// kMaxGhostReflections reflections in all. Its key is kGhostBase + i (ghostChains(); a
// designed chain's key is its k), solved as a designed one: the same seed grid, Newton's
// method and Jacobian over its own crossings. The pilot follows every photon's reflections
// at the designed path's refracting faces along such routes (kGhostPilotPhotons per source);
// a route is a chain of (source, object) where it carries at least kGhostShare of the pilot's
// light that reaches the object by the chains and kGhostFloor of all the source's light that
// reaches scattering objects by them, up to kGhostChains per object. A ghost chain
// keeps its source's own parametrization. advance() follows a photon's key along its
// events, designed or ghost, so the photon pass knows which light the connection owns.
//
// Which light it owns. The chains come from a pilot: photons of each source drawn once
// (fixed seed) and followed along the designed path only; where one first meets a scattering
// object after k >= 1 designed crossings, (source, object, k) is a chain (chains()). The
// connection tries a point where its seed node's last segment, turned toward the point,
// reaches it (inView()); the photon pass does not gather the light of that source that
// crossed exactly those k faces as designed before scattering at that object where the same
// test passes for the photon's own hit point and fixed half. Paths the connection misses
// there (several rays of the chain through one point, near a caustic; an aperture's rim)
// stay the photons': a random 1 / kAuditRate of those photons runs the whole connection for
// its own path (finds()) and is gathered kAuditRate times over when it does not end on the
// photon's own ray (unbiased: the audit's expectation is exactly the light the connection
// misses). Everything else (ghosts, light that scattered before, points in a chain's shadow)
// stays gathered. At a followed narrow lobe (tracer/render/backward.h), where nothing is
// gathered, the connection shares the light with the lobe's own sampled direction by
// multiple importance sampling: Light::pdfSr is the connection's density of the direction,
// and found() gives it for a path the lobe found.
//
// Deterministic: no state changes after construction; thread-safe.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "tracer/records/path_history.h"
#include "tracer/render/designed_path.h"
#include "tracer/render/path_judge.h"
#include "tracer/transport/interaction.h"

namespace veil {

class LensConnector {
  public:
    // Photons checked against finds() where the connection owns their light: 1 in this many.
    static constexpr int kAuditRate = 32;
    // Pilot photons per source (LensConnector's constructor).
    static constexpr uint64_t kPilotPhotons = 65536;

    LensConnector() = default;
    // The pilot (see the header comment), for every source; ghost routes too with
    // `ghostRoutes` (RenderOptions::ghostRoutes).
    explicit LensConnector(const TransportView& ts, bool ghostRoutes = true);

    // The chains by which source s lights object `object` through the lens as designed: bit
    // k - 1 set for k designed crossings (k up to 64). 0 for no chain.
    static constexpr int kMaxSteps = 64;  // bits of a chains() mask
    uint64_t chains(size_t source, int object) const {
        if (chains_.empty()) return 0;
        return chains_[source * objects_ + static_cast<size_t>(object)];
    }
    // Ghost routes (the header comment): a chain's key is k for k designed crossings, or
    // kGhostBase + i for ghost route i.
    static constexpr int kGhostBase = 1 << 16;
    static constexpr int kMaxGhostReflections = 2;
    static constexpr uint64_t kGhostPilotPhotons = 4096;
    static constexpr double kGhostShare = 0.05;
    static constexpr double kGhostFloor = 1e-3;
    static constexpr size_t kGhostChains = 8;
    // The ghost chains by which source s lights `object`: their keys, ascending.
    const std::vector<int>& ghostChains(size_t source, int object) const {
        static const std::vector<int> none;
        if (ghostChains_.empty()) return none;
        return ghostChains_[source * objects_ + static_cast<size_t>(object)];
    }
    // Whether source s lights `object` by the chain of key `steps` (a count of designed
    // crossings, 1..kMaxSteps, or a ghost route's key).
    bool hasChain(size_t source, int object, int steps) const {
        if (steps >= kGhostBase) {
            const std::vector<int>& g = ghostChains(source, object);
            return std::binary_search(g.begin(), g.end(), steps);
        }
        return steps >= 1 && steps <= kMaxSteps && ((chains(source, object) >> (steps - 1)) & 1u);
    }
    // The key of the light after an event of type `e` at `object` by light of key `at` (0 as
    // emitted): the next designed step, the ghost route that goes on so (a prefix of a ghost
    // chain's route), or DesignedPath::kOff.
    int advance(int at, int object, EventType e) const {
        if (at == DesignedPath::kOff) return at;
        if (at < kGhostBase) {
            const int next = designed_.forward(at, object, e);
            if (next != DesignedPath::kOff || ghostLastSteps_.empty()) return next;
        }
        const uint64_t code = nodeCode(at, object, e);
        const auto it = std::lower_bound(
            ghostChildren_.begin(), ghostChildren_.end(), code,
            [](const std::pair<uint64_t, int>& c, uint64_t v) { return c.first < v; });
        return it != ghostChildren_.end() && it->first == code ? it->second : DesignedPath::kOff;
    }
    // The designed step of the first face that light a chain of key `steps` brings to a part
    // can meet as the part scatters it on toward the detector as designed (k for a designed
    // chain k; no face before it can be met). A ghost route's light, after an odd number of
    // Fresnel reflections, travels against the designed order: it last met the face of step
    // L (reflected there, or crossed it backward), so the part lies before that face and the
    // light meets it first going on; after an even number it travels in the designed order
    // again, past step L, and meets L + 1 first.
    int onwardFaceStep(int steps) const {
        if (steps < kGhostBase) return steps;
        const size_t g = static_cast<size_t>(steps - kGhostBase);
        size_t reflections = 0;
        for (const auto& [object, event] : ghostRoutes_[g])
            reflections += event == EventType::FresnelReflect ? 1 : 0;
        return reflections % 2 == 1 ? std::max(0, ghostLastSteps_[g])
                                    : std::min(ghostLastSteps_[g] + 1, designed_.steps());
    }
    bool any() const { return any_; }
    // The ways the solve parametrizes source s's rays: 1, or 2 for a narrow-coned area (the
    // header comment, step 1).
    int parametrizations(size_t s) const { return params_.empty() ? 1 : params_[s].count; }
    // The one connect() uses for the chain of `steps` crossings to `object` (0 for a point in
    // the open, or a source with one): 0 the source's own, 1 its other.
    int parametrization(size_t s, int object, int steps) const {
        if (object < 0 || steps < 1 || steps > kMaxSteps || other_.empty()) return 0;
        return static_cast<int>(
            (other_[s * objects_ + static_cast<size_t>(object)] >> (steps - 1)) & 1);
    }

    struct Light {
        Vec3 toLight{0.0};  // unit, from the point back along the arriving ray
        // The irradiance at the point perpendicular to the ray (unit/mm^2), over the pdf of
        // the drawn direction: f |cos| value estimates the light scattered there, as
        // Source::IncidentSample::value.
        double value = 0.0;
        // The density per steradian with which connect() draws toLight at the point, for
        // weighing the connection against a direction sampled from a lobe there (multiple
        // importance sampling): the source's radiance over `value`, by etendue. 0 for the
        // delta kinds (a collimated beam, a point), which no sampled direction meets.
        double pdfSr = 0.0;
        double distanceMm = 0.0;  // of the last segment, from the k-th face
        Ray entry;                // the source's ray that reaches the point
    };
    struct Work {
        uint64_t rays = 0;  // segments traced (each crossing of the chain, shadow rays)
    };

    // Whether the connection tries `point` (on `object`; -1: a point in the open) for the
    // chain of `steps` crossings of source s with the fixed half `fixed` (fixedOf): the last
    // segment of the seed grid's node nearest the point (seed()) reaches it unblocked. A point
    // in a shadow is not solved for; its light, if any, stays the photons'. The same test on a
    // photon's own hit point and fixed half decides whether its light is the connection's.
    bool inView(size_t s, int steps, const Vec3& fixed, const Vec3& point, int object,
                Work& work) const;
    // The fixed half of the emitted ray `entry` in the parametrization of that chain.
    Vec3 fixedOf(size_t s, int object, int steps, const Ray& entry) const;

    // Light of source s, line `line` (model wavelength index), arriving at `point` on `object`
    // (-1: a point in the open) through the chain of `steps` designed crossings, its
    // direction drawn from u1, u2 (the Sun's; ignored by collimated and point sources). None
    // when no ray of the chain reaches the point: outside the beam, blocked, past the critical
    // angle, or the solver did not converge. With `events`, the chain's events as light
    // travels them (after Emit, before the scatter at the point) replace its contents.
    std::optional<Light> connect(size_t s, int line, double wavelengthNm, int steps,
                                 const Vec3& point, int object, double u1, double u2, Work& work,
                                 std::vector<PathEvent>* events = nullptr) const {
        return connectAs(parametrization(s, object, steps), s, line, wavelengthNm, steps, point,
                         object, u1, u2, work, events);
    }
    // The same in parametrization `mode` (< parametrizations(s)).
    std::optional<Light> connectAs(int mode, size_t s, int line, double wavelengthNm, int steps,
                                   const Vec3& point, int object, double u1, double u2, Work& work,
                                   std::vector<PathEvent>* events = nullptr) const;

    // Whether connect() finds the path of the emitted ray `emitted` (of source s) that crossed
    // the chain of `steps` designed crossings and arrived at `point` (on `object`; -1: in the
    // open): with the ray's own fixed half (fixedOf), everything connect() does succeeds (the
    // point in view, the solve, the Jacobian, the flux, the last segment unblocked) and reaches
    // the ray's own entry.
    bool finds(size_t s, int line, double wavelengthNm, int steps, const Vec3& point, int object,
               const Ray& emitted, Work& work) const;
    // The same, with what connect() gives for that path (its pdfSr weighs a path a lobe's
    // sampled direction found against the connection); none where finds() is false.
    std::optional<Light> found(size_t s, int line, double wavelengthNm, int steps,
                               const Vec3& point, int object, const Ray& emitted,
                               Work& work) const {
        return foundAs(parametrization(s, object, steps), s, line, wavelengthNm, steps, point,
                       object, emitted, work);
    }
    std::optional<Light> foundAs(int mode, size_t s, int line, double wavelengthNm, int steps,
                                 const Vec3& point, int object, const Ray& emitted,
                                 Work& work) const;

    // The designed path onward from a point (light traced toward the detector): `start`
    // (leaving object startObject, triangle startPrimitive, in `medium`) meets the faces of
    // steps fromStep, fromStep + 1, ... steps() - 1 in turn, each crossed as designed (the
    // scene's own coatings, apertures and media), and then the detector object
    // `detectorObject` first. None when anything else comes first or a crossing has no
    // designed child (past the critical angle). With `events`, the crossings and the detector
    // hit as light travels them replace its contents.
    struct Onward {
        Vec3 firstPoint{0.0};  // where it met the face of step fromStep (the detector's hit
                               // when fromStep == steps())
        Vec3 firstNormal{0.0};  // the face's orientation there (SceneHit::normal)
        int firstPrimitive = 0;
        SceneHit detectorHit;
        double transmit = 1.0;  // the crossings' shares and the media's absorption
        int medium = 0;         // in which it reached the detector
        // Whether its first crossing is the point y aimed at from `distanceMm` away (to the
        // rounding of the crossing): a ray that meets a curved face first elsewhere is not the
        // aimed one.
        bool firstMeets(const Vec3& y, double distanceMm) const {
            const double tol = 1e-6 * std::max({1.0, std::abs(y.x), std::abs(y.y), std::abs(y.z)}) +
                               1e-7 * distanceMm;
            return glm::length(firstPoint - y) <= tol;
        }
    };
    std::optional<Onward> onward(const Ray& start, int startObject, int startPrimitive, int medium,
                                 int fromStep, int line, double wavelengthNm, int detectorObject,
                                 Work& work, std::vector<PathEvent>* events = nullptr) const;
    const DesignedPath& designed() const { return designed_; }

  private:
    struct Chain;  // one evaluation of the chain (lens_connection.cpp)
    // How a source's entry rays are parametrized: the solver moves the origin on a plane
    // (center, u, v; the direction fixed: beams, narrow-coned areas) or the direction on the
    // plane tangent to the unit sphere at `axis` (the origin fixed: points, wide-coned areas).
    struct Parameters {
        bool movesOrigin = false;
        Vec3 center{0.0}, axis{0.0, 0.0, 1.0}, u{1.0, 0.0, 0.0}, v{0.0, 1.0, 0.0};
        double scale = 1.0;  // of the parameters: mm on a plane, or a tangent
    };
    // A source's parametrizations: [0] its own, [1] (count 2, a narrow-coned area only) the
    // point drawn on the area and the direction solved for.
    struct ParameterSets {
        Parameters set[2];
        int count = 1;
    };
    static ParameterSets parametrize(const Source& src);
    // The half of an entry ray that parametrization p keeps fixed.
    static Vec3 fixedIn(const Parameters& p, const Ray& entry);
    // Where the solver starts: the chain traced once from a grid of kSeedGrid^2 parameters
    // over [-scale, scale]^2, per source, chain and fixed half (one for a beam or a point;
    // kSeedFixes^2 directions over a narrow cone, or points over a wide-coned area); the grid
    // of the fixed half nearest the drawn one, and its node whose last segment passes nearest
    // the point, start Newton's method.
    struct SeedGrid {
        Vec3 fixed{0.0};
        std::vector<Ray> ends;                                // [node]: the last segment
        std::vector<Vec2> params;                             // [node]
        std::vector<int> lastObjects, lastPrimitives, media;  // [node]: where it left, in what
    };
    static constexpr int kSeedGrid = 12;
    static constexpr int kSeedFixes = 5;
    std::vector<Vec3> seedFixes(size_t s, int m) const;
    SeedGrid buildSeeds(size_t s, int m, int steps, const Vec3& fixed) const;
    const SeedGrid* seed(size_t s, int m, int steps, const Vec3& fixed, const Vec3& point,
                         double& a, double& b, size_t* node = nullptr) const;
    bool inViewAs(int m, size_t s, int steps, const Vec3& fixed, const Vec3& point, int object,
                  Work& work) const;
    // Whether `from` (leaving object fromObject, triangle fromPrimitive, in `medium`) first
    // meets `object` at `point` (within the rounding of a mesh's hits), or for object < 0
    // meets nothing before it.
    bool reaches(const Ray& from, int fromObject, int fromPrimitive, int medium, const Vec3& point,
                 int object) const;
    // The entry ray of source s for parameters (a, b) and what the solver keeps fixed: a
    // beam's direction (a, b on its start plane), or the origin of a point or of a point drawn
    // on an emitting area (a, b the direction on the plane tangent to its axis).
    Ray entryRay(size_t s, int m, const Vec3& fixed, double a, double b) const;
    // The source's flux per unit of its parameters at (a, b) (the header comment, step 2).
    double fluxPerParameter(size_t s, int m, int line, const Ray& entry) const;
    // The parameters of an entry ray (the inverse of entryRay).
    void parametersOf(size_t s, int m, const Ray& entry, double& a, double& b) const;
    // The chain of key `steps` from `entry`: each step's face must be the next one met, in the
    // scene (Crossing::Scene: nothing in between, the path's check) or alone (Crossing::Faces:
    // the face itself, whatever lies before it; a mesh step is met in the scene). The solver
    // and the Jacobian move on the faces alone, a smooth map of the parameters that a part
    // beside the path does not cut; the path they find is then checked in the scene.
    enum class Crossing { Scene, Faces };
    bool trace(const Ray& entry, int steps, int line, double wavelengthNm, Chain& out, Work& work,
               std::vector<PathEvent>* events, Crossing crossing = Crossing::Scene) const;
    // Crosses the face met at `hit` by `ray` travelling in `medium` by the event `want` (its
    // designed one, or a ghost's Fresnel reflection): that child's share into `transmit`, its
    // event into `events`, and ray and medium become the child's. False where there is none
    // (past the critical angle).
    bool cross(const SceneHit& hit, EventType want, int line, double wavelengthNm, Ray& ray,
               int& medium, double& transmit, std::vector<PathEvent>* events) const;
    // The crossings of the chain of key `steps`, and crossing i's face and event.
    int lengthOf(int steps) const {
        return steps < kGhostBase ? steps : static_cast<int>(routeOf(steps).size());
    }
    const std::vector<std::pair<int, EventType>>& routeOf(int steps) const {
        return ghostRoutes_[static_cast<size_t>(steps - kGhostBase)];
    }
    bool validKey(int steps) const {
        return (steps >= 1 && steps <= designed_.steps()) ||
               (steps >= kGhostBase &&
                static_cast<size_t>(steps - kGhostBase) < ghostLastSteps_.size());
    }
    // The seed grids' index of a chain of key `steps`.
    static size_t slotOf(int steps) {
        return steps < kGhostBase ? static_cast<size_t>(steps - 1)
                                  : static_cast<size_t>(kMaxSteps + (steps - kGhostBase));
    }
    static uint64_t nodeCode(int at, int object, EventType e) {
        return (static_cast<uint64_t>(static_cast<uint32_t>(at)) << 32) |
               (static_cast<uint64_t>(static_cast<uint32_t>(object)) << 8) |
               static_cast<uint64_t>(e);
    }
    // The pilot's search for ghost routes (the header comment): walkGhosts() follows light
    // that face `step` (met at `hit`) reflected as `reflected`, with `flux`, along the
    // routes, into the pilot's provisional routes; findGhostChains() keeps those that carry
    // enough of an object's light (chainedLight: the designed chains', [source * objects +
    // object]) and fills ghostLastSteps_, ghostRoutes_, ghostChildren_ and ghostChains_.
    struct GhostPilot;
    void walkGhosts(GhostPilot& pilot, size_t s, const SceneHit& hit,
                    const InteractionChild& reflected, int step, double flux, int line,
                    double wavelengthNm) const;
    void findGhostChains(GhostPilot& pilot, const std::vector<double>& chainedLight);
    // connect() with its fixed half given.
    std::optional<Light> connectWith(size_t s, int m, int line, double wavelengthNm, int steps,
                                     const Vec3& point, int object, const Vec3& fixed, Work& work,
                                     std::vector<PathEvent>* events) const;
    // Newton's method for the entry parameters whose chain passes through `point`, from the
    // straight line to it (the same start for every caller: finds() must see what connect()
    // sees).
    bool solve(size_t s, int m, int line, double wavelengthNm, int steps, const Vec3& point,
               const Vec3& fixed, double& a, double& b, Work& work) const;
    // |det| of the Jacobian of the point where the chain crosses the plane through `point`
    // perpendicular to `at`'s last segment, by the entry parameters (central differences);
    // 0 where it cannot be formed.
    double jacobian(size_t s, int m, int line, double wavelengthNm, int steps, const Vec3& point,
                    const Vec3& fixed, double a, double b, const Chain& at, Work& work) const;

    const TransportView* ts_ = nullptr;
    DesignedPath designed_;
    size_t objects_ = 0;
    std::vector<uint64_t> chains_;  // [source * objects + object]
    // Ghost routes: a node per route prefix that leads to a ghost chain (key kGhostBase + i):
    // the designed step of the last face it meets (onwardFaceStep()), the crossings from the
    // source to it, and its children (nodeCode(parent key, object, event), key) sorted.
    std::vector<int> ghostLastSteps_;
    std::vector<std::vector<std::pair<int, EventType>>> ghostRoutes_;
    std::vector<std::pair<uint64_t, int>> ghostChildren_;
    std::vector<std::vector<int>> ghostChains_;  // [source * objects + object]: keys

    std::vector<ParameterSets> params_;  // [source]
    // [source * objects + object]: bit k - 1 set where the chain of k crossings uses the
    // source's other parametrization (parametrization()).
    std::vector<uint64_t> other_;
    // [source][parametrization][slotOf(key)][fixed half]
    std::vector<std::vector<std::vector<std::vector<SeedGrid>>>> seeds_;
    bool any_ = false;
};

}  // namespace veil
