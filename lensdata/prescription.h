#pragma once
// The lens prescription: a sequential model of N surfaces (N-1 gaps), plus system data.
//
//   surface:   0 (object)   1        2        3 ...      N-1 (image)
//   gap:              0         1        2       ...  N-2
//   medium:    surfaces[i].material fills gap i, from surface i to surface i+1.
//
// Sign conventions are those of lens design programs: light travels toward +z at the start;
// radius > 0 when the centre of curvature lies at +z of the vertex; thicknessMm is the signed
// vertex-to-vertex distance along z to the next surface (negative after an odd number of
// mirrors). A mirror keeps the medium: the material of a mirror surface is the medium the
// light came from. Lengths in mm, wavelengths in nm, angles in degrees.

#include <array>
#include <limits>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "lensdata/errors.h"
#include "lensdata/glass.h"

namespace veil {

// What fills a gap.
struct Material {
    enum class Kind { Air, Catalog, Model, Table, Formula };
    Kind kind = Kind::Air;
    // Catalog: the catalog glass's name; Table and Formula: the glass's own name.
    std::string name;
    double nd = 1.0;    // Kind::Model
    double vd = 0.0;    // Kind::Model; 0 = constant index (no dispersion)
    double dPgF = 0.0;  // Kind::Model
    // Kind::Table: indices at wavelengths (nm), as Glass::table() takes them.
    std::vector<double> tableNm;
    std::vector<double> tableIndex;
    // Kind::Formula: a dispersion formula and its coefficients (a CODE V private glass given
    // by its Laurent coefficients, LAU, is the Schott formula).
    DispersionFormula formula = DispersionFormula::Schott;
    std::vector<double> coefficients;

    static Material air() { return {}; }
    static Material catalog(std::string glassName) {
        Material m;
        m.kind = Kind::Catalog;
        m.name = std::move(glassName);
        return m;
    }
    static Material model(double nd, double vd, double dPgF = 0.0) {
        Material m;
        m.kind = Kind::Model;
        m.nd = nd;
        m.vd = vd;
        m.dPgF = dPgF;
        return m;
    }
    static Material table(std::string name, std::vector<double> wavelengthsNm,
                          std::vector<double> indices) {
        Material m;
        m.kind = Kind::Table;
        m.name = std::move(name);
        m.tableNm = std::move(wavelengthsNm);
        m.tableIndex = std::move(indices);
        return m;
    }
    static Material withFormula(std::string name, DispersionFormula formula,
                                std::vector<double> coefficients) {
        Material m;
        m.kind = Kind::Formula;
        m.name = std::move(name);
        m.formula = formula;
        m.coefficients = std::move(coefficients);
        return m;
    }
    // The glass of a Model, Table or Formula material; nullopt for the others.
    std::optional<Glass> ownGlass() const;
    bool isAir() const { return kind == Kind::Air; }
    std::string label() const;  // "AIR", "N-BK7", "model 1.5168/64.17", "E48 (table)"
    bool operator==(const Material&) const = default;
};
std::ostream& operator<<(std::ostream& os, const Material& m);

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

// A coordinate break (Zemax COORDBRK, CODE V ADE/XDE/YDE on a dummy surface): a flat dummy
// surface whose own coordinate system, and that of every surface after it, is the incoming
// one decentered and tilted. Order 0 decenters along the incoming x and y, then tilts about
// x, then the new y, then the new z; tiltFirst (the Zemax order flag) tilts about z, y, x,
// then decenters along the tilted axes, so a break with every value negated and the order
// flipped undoes it. Tilts about x and y are left-handed and about z right-handed, as in lens
// design programs: a positive tilt about x turns the z axis toward +y, about y toward -x,
// and about z turns the x axis toward +y. The break's thickness runs along the new z axis.
// Sequential rays are not traced to the break itself (it is not a surface light meets); the
// paraxial trace sees a plane in the same medium, so first-order data ignore breaks, as in
// lens design programs.
struct CoordinateBreak {
    double decenterXMm = 0.0;
    double decenterYMm = 0.0;
    double tiltXDeg = 0.0;
    double tiltYDeg = 0.0;
    double tiltZDeg = 0.0;
    bool tiltFirst = false;
    bool identity() const {
        return decenterXMm == 0.0 && decenterYMm == 0.0 && tiltXDeg == 0.0 && tiltYDeg == 0.0 &&
               tiltZDeg == 0.0;
    }
    bool operator==(const CoordinateBreak&) const = default;
};
std::ostream& operator<<(std::ostream& os, const CoordinateBreak& b);

// An anamorphic surface: no symmetry of revolution (geometry/surface_shape.h has the sags).
// The surface's curvature and conic are those of its y-z section, as in lens design programs.
// Toroidal (Zemax TOROIDAL): the y-z profile (curvature, conic and the even asphere terms, in
// y alone) is swept about the axis parallel to y at the radius of rotation 1 / xCurvature from
// the vertex; xCurvature 0 (an infinite radius) makes a cylinder lens surface, flat in x.
// Biconic (Zemax BICONICX): the x-z section is the conic (xCurvature, xConic); no asphere
// terms. Paraxial data are those of the y-z section; Prescription::xSection() gives the
// x-z one.
struct Anamorphic {
    enum class Kind { Toroidal, Biconic };
    Kind kind = Kind::Toroidal;
    double xCurvature = 0.0;  // 1/mm
    double xConic = 0.0;      // biconic only
    const char* label() const { return kind == Kind::Toroidal ? "toroidal" : "biconic"; }
    bool operator==(const Anamorphic&) const = default;
};
std::ostream& operator<<(std::ostream& os, const Anamorphic& a);

// A Forbes Q-polynomial asphere (geometry/qtype.h): the departure from the base conic
// (Qcon) or best-fit sphere (Qbfs, conic 0) as terms a_0 .. a_8 of Forbes's polynomials of
// (r / normRadiusMm)^2. Both are traced exactly, as even asphere terms.
struct QAsphere {
    enum class Kind { Bfs, Con };
    Kind kind = Kind::Con;
    double normRadiusMm = 0.0;
    std::vector<double> terms;  // mm
    bool operator==(const QAsphere&) const = default;
};
std::ostream& operator<<(std::ostream& os, const QAsphere& q);

struct Surface {
    std::string name;     // stable name: object, L1.front, L1.back, stop, M1, image, S7, ...
    std::string comment;  // free text from the lens file

    double curvature = 0.0;  // 1/mm, 0 = flat
    double conic = 0.0;      // k: 0 sphere, -1 paraboloid, < -1 hyperboloid
    // Even asphere: sag += sum_i asphere[i] r^(2i+2), so asphere[0] multiplies r^2 and
    // asphere[1..9] are A4..A20.
    std::array<double, 10> asphere{};
    // Odd asphere terms (Zemax ODDASPH): sag += sum_j oddAsphere[j] r^(2j+3), r^3 .. r^19.
    std::array<double, 9> oddAsphere{};
    std::optional<QAsphere> qAsphere;  // a Q-type departure (then asphere and oddAsphere are 0)
    std::optional<Anamorphic> anamorphic;  // set: curvature and conic are the y-z section's
    double thicknessMm = 0.0;  // to the next surface; may be +-kInfinity for the object
    Material material;         // medium after this surface (gap index = this surface's index)

    // Clear (optical) semi-diameter and mechanical semi-diameter, mm. 0 = not given: the
    // clear aperture is then computed from the marginal and chief rays (see analysis).
    double clearSemiDiameterMm = 0.0;
    double mechSemiDiameterMm = 0.0;
    // The clear semi-diameter was computed by the program that wrote the file (a Zemax DIAM
    // without a fixed solve): it sizes the part but does not vignette sequential rays, as in
    // that program. A semi-diameter the user fixed does vignette.
    bool semiDiameterAutomatic = false;
    // Central hole or obscuration, mm; 0 = none. The clear aperture is then the annulus from
    // innerSemiDiameterMm to clearSemiDiameterMm (0 <= inner < clear; a hole needs a clear
    // semi-diameter). Sequential rays inside it are Clipped (a hole is never computed, so it
    // clips even where the outer semi-diameter does not); in the scene a mirror in air gets
    // an annular face, so light passes through the hole (a Cassegrain primary).
    double innerSemiDiameterMm = 0.0;

    bool stop = false;
    bool mirror = false;
    // Set: this surface is a coordinate break (flat, no aperture, the medium continues).
    std::optional<CoordinateBreak> coordinateBreak;
    std::string coating;  // coating or surface property name; empty = default for the scene

    FileLoc origin;  // where in the input file this surface was defined

    double radiusMm() const { return curvature == 0.0 ? kInfinity : 1.0 / curvature; }
    bool hasAsphere() const;
};
std::ostream& operator<<(std::ostream& os, const Surface& s);

// A lens element: glass between two surfaces. Cemented neighbours share a surface.
struct Element {
    std::string name;  // "L1", "L2", ...
    int frontSurface = 0;
    int backSurface = 0;
    Material material;
};
std::ostream& operator<<(std::ostream& os, const Element& e);

// How the system aperture is specified.
struct SystemAperture {
    enum class Kind {
        EntrancePupilDiameter,  // value: mm
        ImageSpaceFNumber,      // value: F/# = EFL / EPD (infinite conjugates)
        ObjectSpaceNA,          // value: n sin(theta) of the marginal ray in object space
        FloatByStop,            // value unused: the stop's clear semi-diameter sets it
    };
    Kind kind = Kind::EntrancePupilDiameter;
    double value = 0.0;
};
std::ostream& operator<<(std::ostream& os, const SystemAperture& a);

struct Field {
    double x = 0.0;  // degrees for angle fields, mm for object and image heights
    double y = 0.0;
    double weight = 1.0;
    // Vignetting factors (Zemax VDX, VDY, VCX, VCY; CODE V's VUX, VLX, VUY, VLY become these):
    // the beam the designer meant fills the pupil points (vdx + px (1 - vcx), vdy + py (1 -
    // vcy)) for px, py on the unit pupil. They size the automatic clear semi-diameters, as in
    // the programs that write them; the scene's light is vignetted by its apertures.
    double vdx = 0.0, vdy = 0.0, vcx = 0.0, vcy = 0.0;
    bool vignetted() const { return vdx != 0.0 || vdy != 0.0 || vcx != 0.0 || vcy != 0.0; }
};

struct Wavelength {
    double nm = 0.0;
    double weight = 1.0;
};

struct SystemData {
    std::string name;
    std::string notes;
    SystemAperture aperture;
    // Image heights (paraxial: on the paraxial image plane; real: where the real chief ray
    // meets the image surface) are what a file may give; resolveImageHeightFields()
    // (tracer/sequential/image_fields.h) turns them into angles or object heights before any trace,
    // and keeps them in imageHeights.
    enum class FieldKind { AngleDeg, ObjectHeightMm, ParaxialImageHeightMm, RealImageHeightMm };
    FieldKind fieldKind = FieldKind::AngleDeg;
    FieldKind givenFieldKind = FieldKind::AngleDeg;  // as the file gave them
    std::vector<Field> imageHeights;                 // the file's image heights, once resolved
    bool rectangularField = false;  // fields span a rectangle (x, y) rather than a radius
    std::vector<Field> fields;
    std::vector<Wavelength> wavelengths;
    int primaryWavelength = 0;               // index into wavelengths
    std::vector<std::string> glassCatalogs;  // preferred catalogs, in order (ZMX GCAT)
};

// A line of an import report: something in the input that was not used as written.
struct ImportNote {
    enum class Severity { Info, Warning, Error };
    // What the note is about, for the reports that group them: a glass taken for another or
    // not found (Glass; the successor a legacy name denotes is an Info worth showing), a
    // command of the file that veil does not read (UnknownCommand, `subject` its name, line
    // and count), anything else.
    enum class Topic { General, Glass, UnknownCommand };
    ImportNote() = default;
    ImportNote(Severity s, FileLoc at, std::string text, Topic about = Topic::General,
               std::string what = {})
        : severity(s),
          loc(std::move(at)),
          message(std::move(text)),
          topic(about),
          subject(std::move(what)) {}
    Severity severity = Severity::Warning;
    FileLoc loc;
    std::string message;
    Topic topic = Topic::General;
    std::string subject;
};
std::ostream& operator<<(std::ostream& os, const ImportNote& n);

struct Prescription {
    SystemData system;
    std::vector<Surface> surfaces;  // [0] object ... [N-1] image
    std::vector<ImportNote> report;
    std::string sourceFile;

    int stopIndex() const;  // the surface flagged stop; the first surface if none
    int imageIndex() const { return static_cast<int>(surfaces.size()) - 1; }
    // Lens elements, found from the gaps that hold glass.
    std::vector<Element> elements() const;
    // Gives surfaces their stable names (object, L<k>.front/.back, M<k>, stop, image, S<i>)
    // unless a name was already set by the input file. Cemented faces take the name of the
    // element in front (L2.back); aliasesOf() lists the other name (L3.front).
    void assignNames();
    std::vector<std::string> aliasesOf(int surfaceIndex) const;
    // Structural checks: at least object, one surface and image; finite thicknesses except
    // the object's; a mirror's material equals the incident medium; and so on. Throws
    // ModelError naming the surface.
    void validate() const;
    // Appends a Warning to `report` for each value that parses and validates but is most
    // likely a mistake, naming the surface: a radius under a micrometre; a semi-diameter
    // beyond the height the surface reaches (|R| / sqrt(1 + k) for a conic, either section
    // of a biconic); glass of zero thickness or thickness against the light's direction
    // (mirrors turn it); a negative air gap between two surfaces that are not dummies (flat,
    // air on both sides). The readers call it after validate().
    void notePlausibility();
    // The first anamorphic surface, -1 if every surface is one of revolution.
    int firstAnamorphic() const;
    // The x-z section of an anamorphic system as a system of revolution: every anamorphic
    // surface replaced by the surface of revolution with its x-z section's curvature (and,
    // for a biconic, conic), so that paraxial data of the result are the x section's.
    Prescription xSection() const;
};

}  // namespace veil
