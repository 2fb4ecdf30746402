#pragma once
// The scene's optical properties by name, and which object gets which.
//
// Properties come from built-ins and from the scene's [properties.NAME] tables; [[assign]]
// rules give them to objects by name glob. Keys and examples: docs/format.md, section
// "[properties] and [[assign]]".
//
//   TomlDocument doc = TomlDocument::fromFile("scene.toml");
//   PropertyTable table = PropertyTable::read(doc);   // errors at file:line:col
//   ...                                               // other readers, doc.checkAllUsed()
//   std::vector<int> of = table.resolve(scene);       // [object id] -> index in properties()
//
// Built-in names (a [properties.NAME] table of the same name replaces them):
//   uncoated      Fresnel from the two media's indices (unpolarised, with TIR)
//   ideal_ar      R = 0, T = 1 (TIR still reflects)
//   absorber      absorbs everything
//   mirror        specular reflectance 1
//   ground_glass  Lambertian scatter, reflectance 0.5 and transmittance 0.5, nothing specular
//                 (the seed paper's fine-ground butt ends)
//   lens_edge     the default of lens butt ends: the same as ground_glass
//   lens_flat     the default of lens flats (the ground shoulders outside the clear aperture):
//                 the same as ground_glass
//
// Which property an object gets (resolve):
//   1. its own property name (SceneObject::property: a surface's `coating`, a part's
//      `property`), when set. The names the lens builder writes when the scene gives none,
//      lens_edge on butt ends and lens_flat on flats, count as not set, so rules reach them;
//   2. otherwise the last [[assign]] rule whose glob matches its name or one of its aliases;
//   3. otherwise the default for its kind: lens faces uncoated, mirror faces mirror, butt
//      ends lens_edge, flats lens_flat, the stop, mechanics, imported meshes and detectors
//      absorber, dummy surfaces ideal_ar.
// The lens-edge default scatters (ground glass) rather than absorbs: unblackened ground edges
// are what a lens has unless someone paints them, and a stray-light estimate should err on
// the bright side. Mechanics default to absorbers: give them a [properties] table (black
// anodized aluminium scatters a few percent) to see their contribution.

#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "tracer/surfaces/optical_property.h"

namespace veil {

class TomlDocument;
class SequentialModel;

// One [[assign]] entry: objects whose name (or an alias) matches one of the globs get the
// property.
struct AssignRule {
    std::vector<std::string> patterns;  // * = any run of characters, ? = any one character
    std::vector<FileLoc> patternLocs;   // where each pattern is written (for errors)
    std::string property;
    FileLoc loc;  // the entry
};
std::ostream& operator<<(std::ostream& os, const AssignRule& r);

// Whole-string glob match: '*' matches any run of characters (dots included), '?' one.
bool globMatch(std::string_view pattern, std::string_view text);

// Whether a coating pattern reaches this object: its name or an alias matches. A pattern
// with wildcards ('L*.*', 'L3.*') means the optical faces a user coats: it leaves out the
// butt ends unless it spells "edge", the flats unless it spells "flat", and cemented
// interfaces (glass on both sides), which only their own name reaches.
bool coatingPatternReaches(std::string_view pattern, const SceneObject& o);
// An optical face with glass on both sides (a cemented interface).
bool isCementedFace(const SceneObject& o);
// Every name the objects answer to (names, then aliases), for did-you-mean suggestions.
std::vector<std::string> namesAndAliases(const std::vector<SceneObject>& objects);

class PropertyTable {
  public:
    // The built-ins only.
    PropertyTable();
    // Built-ins plus the document's [properties.*] tables and [[assign]] entries (both may be
    // absent). ParseError at the value at fault. Unknown keys are left for checkAllUsed().
    static PropertyTable read(const TomlDocument& doc);

    // Adds a property, or replaces the one of the same name; returns its index.
    int define(OpticalProperty p);
    // Appends a rule; its property must be defined (ModelError naming it otherwise).
    void addRule(AssignRule rule);

    int find(std::string_view name) const;  // index, or -1
    const OpticalProperty& property(int index) const { return properties_[index]; }
    const std::vector<OpticalProperty>& properties() const { return properties_; }
    const std::vector<AssignRule>& rules() const { return rules_; }

    // The property index of every object (by id). Throws ParseError at a rule pattern that
    // matches no object, and ModelError naming the object for a property name that is not
    // defined.
    std::vector<int> resolve(const Scene& scene) const;
    // The lens faces between glass and air (or another gas-like medium index: not cemented)
    // whose resolved property reflects by bare Fresnel: uncoated, whether by default or by
    // assignment. Their names, in object order. Throws as resolve() does.
    std::vector<std::string> uncoatedFaces(const Scene& scene) const;

    // Refuses (ModelError naming the property) scatter that would take more than all the
    // light at one of the model's wavelengths: K-correlation roughness past the smooth-surface
    // limit, its BRDF (from air and from the densest medium) and BTDF (air into the densest
    // medium) together over incidence angles 0 to 89 degrees.
    void checkScatterEnergy(const SequentialModel& model) const;

    // The name of the default property of a kind (rule 3 above).
    static std::string_view defaultName(ObjectKind kind);
    static bool isBuiltInName(std::string_view name);

  private:
    std::vector<OpticalProperty> properties_;
    std::vector<AssignRule> rules_;
};
std::ostream& operator<<(std::ostream& os, const PropertyTable& t);

}  // namespace veil
