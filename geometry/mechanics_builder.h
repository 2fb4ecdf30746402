#pragma once
// The mount generator's builder, internal to geometry/: the definitions mechanics.cpp,
// mechanics_builder.cpp and mechanics_parts.cpp share. Users call buildMechanics()
// (mechanics.h); the model is described there and in mechanics.cpp.
//
//   Prescription + MechanicsSpec --MechanicsBuilder::build-->
//     readSurfaces, makeBodies, makePaths, makeRegions       the lens as bodies and light paths
//     makePlates, computeBores, placePlates                  stop, field stop, baffles, vanes
//     makeSpacersAndRetainers, makeBarrel                    rings and the barrel
//     checkParts                                             every part against the glass
//
// Lengths in mm; z is global (surface 1's vertex at 0). Radii (r) are distances from the axis.

#include <functional>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "geometry/mechanics.h"
#include "geometry/surface_shape.h"

namespace veil::mechanics_detail {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDefaultStopThicknessMm = 0.5;
// Radial room a plate (stop, field stop, baffle) gets at least between its aperture and the
// bore, and the spacer wall a simple gap's bore leaves outside the beam.
constexpr double kMinPlateWidthMm = 1.0;
constexpr double kSpacerWallMm = 0.5;
// Thinnest ring (spacer, retainer) worth building, radially.
constexpr double kMinRingWallMm = 0.05;
// Clearance checks against glass sample both boundaries this densely.
constexpr double kCheckStepMm = 0.005;
constexpr size_t kMaxCheckSamplesPerEdge = 400000;
// Deeper than this is a collision (contacts keep contact_gap_mm, far more).
constexpr double kPenetrationMm = 1e-9;
// Placement optimizes over radii with this many samples, then refines the best.
constexpr int kPlacementSamples = 1024;
// Retainer inner radii widen by width * tan(field angle), the angle capped here.
constexpr double kMaxFieldDeg = 60.0;

inline std::string fmt(double v, int decimals = 3) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(decimals) << v;
    return os.str();
}

// Lens Model Definitions

struct SurfaceInfo {
    std::string name;
    SurfaceShape shape;
    double zMm = 0.0;
    double clearMm = 0.0;  // sd, or mech_sd when sd is not given
    double mechMm = 0.0;   // mech_sd, or sd
    int body = -1;         // body holding it: -1 for object, image, free stop, dummies
    double at(double r) const { return zMm + sag(shape, r * r); }
};

// One lens element or one mirror without glass: the unit of the glass clearance check.
struct Piece {
    std::string name;           // "L3", "M1"
    std::vector<int> surfaces;  // element: front and back; sheet: the mirror
    // Per surface: the radius a cemented face runs out to (the smaller element's radius,
    // geometry/lens_solid.h), 0 for a face that ends at its clear aperture.
    std::vector<double> cementedTo;
    bool sheet = false;
    int elementNumber = 0;  // k of Lk; 0 for sheets
    double radiusMm = 0.0;
};

// What a seat holds: cemented elements (one group), or one mirror sheet.
struct Body {
    std::vector<int> pieces;
    std::string name;  // "L2+L3", "M1"
    bool sheet = false;
    double radiusMm = 0.0;
    double zMin = 0.0, zMax = 0.0;
    int spacerNumber = 0;  // spacers behind it are spacer<k>: its last element's number
    double boreMm = 0.0;
};

// Light between two physical surfaces (object, glass faces, mirrors, image), through any
// stop or dummy surface between them.
struct Path {
    int from = 0, to = 0;  // surface indices
    double beamMm = 0.0;   // largest clear semi-diameter along it
    // Places of its end points in the stack: body j is 2 j + 1, region k is 2 k (an end
    // point that is no body, the object or the image, lies in the region holding its z).
    int lo = 0, hi = 0;
    bool crossesRegion(int k) const { return lo <= 2 * k && 2 * k <= hi; }
    bool crossesBody(int j) const { return lo < 2 * j + 1 && 2 * j + 1 < hi; }
};

enum class PlateKind { Stop, FieldStop, Baffle, Vane };

// An annular plate: stop, field stop, baffle or vane. Its profile spans radii [ri, ro]; at
// radius r it spans [z0 - hLo(r), z0 + hHi(r)], h growing from edgeHalf at ri along the
// bevel (slope tanBevel) up to tLo / tHi. Plain plates have edgeHalf = tLo = tHi.
struct Plate {
    PlateKind kind = PlateKind::Baffle;
    std::string name;
    std::string property;
    std::string edgeProperty;
    double ri = 0.0, ro = 0.0;
    double z0 = 0.0;
    double edgeHalf = 0.0;
    double tLo = 0.0, tHi = 0.0;
    double tanBevel = 1.0;
    double vaneDepth = 0.0;  // vanes: ri = ro - depth once the bore is known
    int region = 0;
    int pushedAgainst = -1;  // stop on a lens face or mirror: that body
    int pushSide = 0;        // -1: plate below the body (smaller z), +1 above
    bool dropped = false;    // no room for it (placeStop says why): not built

    double hLo(double r) const {
        return std::min(tLo, edgeHalf + std::max(0.0, r - ri) * tanBevel);
    }
    double hHi(double r) const {
        return std::min(tHi, edgeHalf + std::max(0.0, r - ri) * tanBevel);
    }
};

// The space between two bodies adjacent in z (or before the first, after the last).
struct Region {
    int below = -1, above = -1;  // body indices (sorted by z); -1: none
    std::vector<int> paths;
    bool simple = false;
    int path = -1;  // the path through it when simple
    double boreMm = 0.0;
    std::vector<int> plates;  // sorted by z0
    int widestPlate = -1;     // the plate (not a vane) of largest inner radius, -1: none
};

// Something a spacer or retainer rests against.
struct StackItem {
    bool isBody = true;
    int index = 0;
};

// Mechanics Builder Definition

class MechanicsBuilder {
  public:
    MechanicsBuilder(const Prescription& p, const MechanicsSpec& spec,
                     std::vector<std::string>* notes)
        : rx_(p), spec_(spec), notes_(notes) {}
    std::vector<MechanicalPart> build();

  private:
    void readSurfaces();
    void makeBodies();
    void makePaths();
    void makeRegions();
    void makePlates();
    void computeBores();
    void placePlates();
    void placeStop(Plate& stop);
    // Marks the stop plate dropped, with a note saying why and what limits the light instead.
    void dropStop(Plate& p, const std::string& why);
    void makeSpacersAndRetainers();
    void makeBarrel();
    void checkParts();

    // Geometry queries (mm; r >= 0).
    void pieceRange(const Piece& p, double r, double& lo, double& hi) const;
    // Body extent at r; beyond its radius the rim's extent continues outward (the seat or
    // step of the barrel sits there), so neighbours never slide past a lens rim.
    double bodyUpper(int b, double r) const;
    double bodyLower(int b, double r) const;
    // Plate mesh extent at radius r (covering the chordal mesh: profile radii r .. r / c);
    // -inf / +inf where the plate's mesh has nothing.
    double plateUpper(const Plate& p, double r) const;
    double plateLower(const Plate& p, double r) const;
    double itemUpper(const StackItem& it, double r) const;
    double itemLower(const StackItem& it, double r) const;
    double maxOver(const std::function<double(double)>& f, double r0, double r1) const;
    double minOver(const std::function<double(double)>& f, double r0, double r1) const {
        return -maxOver([&](double r) { return -f(r); }, r0, r1);
    }
    int regionOfZ(double z) const;
    double lightDirectionOfGap(int gap) const;
    std::string propertyOr(const std::string& own) const {
        return own.empty() ? spec_.property : own;
    }
    void note(const std::string& text) {
        if (notes_) notes_->push_back(text);
    }
    void addPart(const std::string& name, const std::string& property, std::vector<Vec2> profile,
                 const std::string& edgeName = {}, const std::string& edgeProperty = {});
    void checkAgainstGlass(const MechanicalPart& part) const;

    const Prescription& rx_;
    const MechanicsSpec& spec_;
    std::vector<std::string>* notes_;

    std::vector<SurfaceInfo> surfaces_;
    std::vector<double> directions_;  // per gap: +1 toward +z, -1 toward -z
    std::vector<Piece> pieces_;
    std::vector<Body> bodies_;  // sorted by zMin
    std::vector<Path> paths_;
    std::vector<Region> regions_;
    std::vector<Plate> plates_;
    std::vector<double> breakpoints_;  // radii where extents have kinks
    double fieldTan_ = 0.0;
    int segments_ = 0;
    double cosHalfStep_ = 1.0;  // cos(pi / N): mesh radii lie in [r cos, r]
    std::vector<MechanicalPart> parts_;
};

}  // namespace veil::mechanics_detail
