#include "tracer/scene/scene_spec.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <sstream>

#include "geometry/lens_fit.h"
#include "geometry/lens_solid.h"
#include "geometry/surface_frames.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/input_file.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_document.h"
#include "lensdata/toml_reader.h"
#include "lensdata/toml_writer.h"
#include "tracer/sequential/auto_apertures.h"
#include "tracer/sequential/image_fields.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

namespace {

std::string lowerExtension(const std::filesystem::path& p) {
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

// Every surface gets a clear semi-diameter (traced where the file leaves it open), and the
// file its sequential model: built once, or twice when semi-diameters had to be traced (the
// model clips at them).
// The model of an imported prescription (size() has stopped at any error in its report).
std::shared_ptr<const SequentialModel> modelOf(const Prescription& p, const GlassCatalog& catalog) {
    return std::make_shared<const SequentialModel>(SequentialModel::build(p, catalog));
}

// Sizes that build: the file's, or where they make elements overlap or too thin, fitted to
// the traced bundle (geometry/lens_fit.h), every change a warning in the import report.
void fit(SceneSpec& f, const GlassCatalog& catalog) {
    LensFit fitted;
    try {
        fitted = fitLensSizes(f.prescription, [&] { return tracedSemiDiameters(*f.model); });
    } catch (const ModelError& e) {
        f.sizeError = e;
        return;
    }
    if (fitted.changes.empty()) return;
    f.prescription = std::move(fitted.prescription);
    for (const LensSizeChange& c : fitted.changes)
        f.prescription.report.push_back(
            {ImportNote::Severity::Warning, c.origin, "sized to fit: " + describe(c)});
    f.sizeChanges = std::move(fitted.changes);
    f.model =
        std::make_shared<const SequentialModel>(SequentialModel::build(f.prescription, catalog));
}

// Mirrors in air that the light passes back through (a Cassegrain primary without the hole
// its file does not give): the scene's mirror gets the hole, with a warning.
void openMirrorHoles(SceneSpec& f) {
    if (f.sizeError) return;
    const std::vector<double> holes = returningLightHoles(*f.model);
    Prescription named = f.prescription;
    named.assignNames();
    for (size_t i = 0; i < holes.size(); ++i) {
        if (holes[i] <= 0.0) continue;
        const Surface& s = named.surfaces[i];
        // A central hole fits a mirror on the axis of the light; in a folded or off-axis
        // system the light crosses the whole parent mirror the file gives (its used segment
        // is an aperture veil does not import), which is said instead.
        if (!f.model->coaxial()) {
            f.prescription.report.push_back(
                {ImportNote::Severity::Warning, s.origin,
                 "the light comes back through " + s.name +
                     "'s place (out to r = " + messageNumber(holes[i]) +
                     " mm from its vertex): the scene's mirror is the "
                     "whole disc the file gives, which stops that light; give it the aperture "
                     "of the segment the light uses"});
            continue;
        }
        if (holes[i] >= s.clearSemiDiameterMm) {
            f.prescription.report.push_back(
                {ImportNote::Severity::Warning, s.origin,
                 "the light comes back through " + s.name +
                     "'s place out to its rim (r = " + messageNumber(holes[i]) +
                     " mm): no hole is opened, and the mirror stops "
                     "that light in the scene"});
            continue;
        }
        if (f.mirrorHoles.empty()) f.mirrorHoles.assign(holes.size(), 0.0);
        f.mirrorHoles[i] = holes[i];
        f.prescription.report.push_back(
            {ImportNote::Severity::Warning, s.origin,
             s.name + ": a central hole of " + messageNumber(holes[i]) +
                 " mm semi-diameter is opened in the scene: the light comes back through the "
                 "mirror's place there (a sequential trace passes it, so the file gives no "
                 "hole); give the hole (hole_sd, or OBSC/CLAP in Zemax) to size it yourself"});
    }
}

void size(SceneSpec& f, const Prescription& given, const GlassCatalog& catalog) {
    // An error in the import report (a glass no catalog has, a surface type veil does not
    // model, a field type it cannot read) stops here, before anything is built: the first at
    // its place in the file, every other one after it.
    std::vector<const ImportNote*> errors;
    for (const ImportNote& n : given.report)
        if (n.severity == ImportNote::Severity::Error) errors.push_back(&n);
    if (!errors.empty()) {
        std::ostringstream more;
        for (size_t i = 1; i < errors.size(); ++i) more << "\n  and " << *errors[i];
        throw ParseError(errors.front()->loc, errors.front()->message + more.str());
    }
    // Image-height fields become angles or object heights first: everything after traces
    // from object space.
    const Prescription p = resolveImageHeightFields(given, catalog);
    auto model = modelOf(p, catalog);
    bool open = false;
    for (size_t i = 1; i < p.surfaces.size(); ++i)
        open |= !(p.surfaces[i].clearSemiDiameterMm > 0.0) && !p.surfaces[i].coordinateBreak;
    if (!open) {
        f.prescription = p;
        f.model = std::move(model);
    } else {
        f.prescription = withAutomaticSemiDiameters(*model);
        f.model = std::make_shared<const SequentialModel>(
            SequentialModel::build(f.prescription, catalog));
    }
    fit(f, catalog);
    openMirrorHoles(f);
}

// A lens file's coating names (Zemax COAT, CODE V) that no optical property of the scene
// defines leave their faces at the scene's default for lens faces, with one warning per name:
// a vendor's coating name says nothing veil can trace, and it should not stop the build.
void dropUnknownCoatings(SceneSpec& f) {
    Prescription named = f.prescription;
    named.assignNames();
    std::vector<std::string> order;
    std::map<std::string, std::vector<int>> faces;
    for (size_t i = 0; i < named.surfaces.size(); ++i) {
        const std::string& c = named.surfaces[i].coating;
        if (c.empty() || f.properties.find(c) >= 0) continue;
        if (!faces.count(c)) order.push_back(c);
        faces[c].push_back(static_cast<int>(i));
    }
    for (const std::string& c : order) {
        std::string list;
        for (int i : faces[c]) {
            list += (list.empty() ? "" : ", ") + named.surfaces[i].name;
            f.prescription.surfaces[i].coating.clear();
        }
        f.prescription.report.push_back(
            {ImportNote::Severity::Warning, named.surfaces[faces[c].front()].origin,
             "coating '" + c + "' is not an optical property veil knows: " + list +
                 (faces[c].size() > 1 ? " are" : " is") +
                 " left uncoated (the scene's default for lens faces); a scene can define it "
                 "in [properties." +
                 c + "]"});
    }
}

}  // namespace

namespace {

bool editsLens(const SceneEdit& e) {
    return e.key == "system" || e.key.starts_with("system.") || e.key.starts_with("system[");
}

// An imported lens (Zemax, CODE V) as a TOML document to edit: the lens written as veil's
// own lens file (lensdata/toml_writer.h), its errors named "FILE as TOML".
TomlDocument importedAsToml(const std::filesystem::path& lensPath, const Prescription& imported,
                            const GlassCatalog& catalog) {
    return TomlDocument::fromString(
        prescriptionToml(imported, catalog, lensPath.filename().string()),
        lensPath.string() + " as TOML");
}

// The import's report goes with the edited lens: what the file held that veil did not keep.
void keepImportReport(Prescription& edited, const Prescription& imported) {
    edited.report.insert(edited.report.begin(), imported.report.begin(), imported.report.end());
    edited.sourceFile = imported.sourceFile;
}

}  // namespace

bool editsTransportOnly(const std::string& key) {
    for (const char* top : {"properties", "assign", "source"})
        if (key == top || key.starts_with(std::string(top) + ".") ||
            key.starts_with(std::string(top) + "["))
            return true;
    return false;
}

namespace {

// An edit of a scene or lens document. The aperture is one of f_number, epd_mm, object_na
// and float_by_stop: setting one replaces the kind the file gives (so that
// `--set system.aperture.f_number=2` works on a lens whose aperture floats by the stop).
void applyEdit(TomlDocument& doc, const SceneEdit& e) {
    static const char* const kinds[] = {"f_number", "epd_mm", "object_na", "float_by_stop"};
    constexpr std::string_view prefix = "system.aperture.";
    if (e.key.rfind(prefix, 0) == 0) {
        const std::string kind = e.key.substr(prefix.size());
        if (std::find(std::begin(kinds), std::end(kinds), kind) != std::end(kinds))
            for (const char* other : kinds)
                if (kind != other) doc.eraseIfPresent("system.aperture", other);
    }
    doc.set(e.key, e.value, e.origin);
}

}  // namespace

void checkSceneEdits(const std::filesystem::path& path, const std::vector<SceneEdit>& edits) {
    if (edits.empty()) return;
    // An imported lens is written as TOML when it is read; its edits are checked then.
    if (lowerExtension(path) != ".toml") return;
    if (!inputFileExists(path)) throw ParseError({path.string(), 0, 0}, "no such file");
    TomlDocument doc = TomlDocument::fromFile(path);
    const TomlTable root = doc.root();
    const auto lens = root.has("lens") ? root.get("lens") : std::nullopt;
    std::optional<TomlDocument> lensDoc;
    for (const SceneEdit& e : edits) {
        if (!(lens && editsLens(e))) {
            applyEdit(doc, e);
            continue;
        }
        const std::filesystem::path lensPath = path.parent_path() / lens->asString();
        if (lowerExtension(lensPath) != ".toml") continue;  // checked as it is read
        if (!lensDoc) lensDoc = TomlDocument::fromFile(lensPath);
        applyEdit(*lensDoc, e);
    }
}

namespace {

SceneSpec readSceneDocument(const std::filesystem::path& path, TomlDocument& doc,
                            const GlassCatalog& catalog, const std::vector<SceneEdit>& edits,
                            const Prescription* imported);

}  // namespace

SceneSpec readSceneFile(const std::filesystem::path& path, const GlassCatalog& catalog,
                        const std::vector<SceneEdit>& edits) {
    if (lowerExtension(path) != ".toml") {
        const Prescription imported = readLensFile(path, catalog);
        if (edits.empty()) {
            SceneSpec f;
            f.path = path;
            size(f, imported, catalog);
            dropUnknownCoatings(f);
            return f;
        }
        // Edited: the lens as veil's own lens file, edited and read as one.
        TomlDocument doc = importedAsToml(path, imported, catalog);
        return readSceneDocument(path, doc, catalog, edits, &imported);
    }
    if (!inputFileExists(path)) throw ParseError({path.string(), 0, 0}, "no such file");
    TomlDocument doc = TomlDocument::fromFile(path);
    return readSceneDocument(path, doc, catalog, edits, nullptr);
}

namespace {

// A scene or lens document (`imported`: the lens it was written from, or null).
SceneSpec readSceneDocument(const std::filesystem::path& path, TomlDocument& doc,
                            const GlassCatalog& catalog, const std::vector<SceneEdit>& edits,
                            const Prescription* imported) {
    SceneSpec f;
    f.path = path;
    const TomlTable root = doc.root();
    const auto lens = root.has("lens") ? root.get("lens") : std::nullopt;
    for (const SceneEdit& e : edits)
        if (!(lens && editsLens(e))) applyEdit(doc, e);
    // Neither a lens file nor [system]: a misspelt top-level key is the likelier cause.
    if (!lens && !root.has("system")) {
        for (const auto& [key, value] : root.table()) {
            const std::string guess = closestSpelling(key.str(), {"lens", "system"});
            if (guess.empty()) continue;
            root.get(key.str())->fail("unknown key '" + std::string(key.str()) +
                                      "' (did you mean '" + guess +
                                      "'?): a scene names its lens with `lens = \"file\"` or "
                                      "holds it in [system]");
        }
    }
    if (lens) {
        if (root.has("system"))
            lens->fail(
                "a scene names its lens either with `lens = \"file\"` or inline in "
                "[system], not both");
        const std::filesystem::path lensPath = path.parent_path() / lens->asString();
        if (!inputFileExists(lensPath))
            lens->fail("lens file '" + lensPath.string() + "' does not exist");
        std::vector<SceneEdit> lensEdits;
        for (const SceneEdit& e : edits)
            if (editsLens(e)) lensEdits.push_back(e);
        if (lensEdits.empty()) {
            size(f, readLensFile(lensPath, catalog), catalog);
        } else if (lowerExtension(lensPath) != ".toml") {
            const Prescription lensImport = readLensFile(lensPath, catalog);
            TomlDocument lensDoc = importedAsToml(lensPath, lensImport, catalog);
            for (const SceneEdit& e : lensEdits) applyEdit(lensDoc, e);
            Prescription p = readTomlPrescription(lensDoc, catalog);
            lensDoc.checkAllUsed();
            keepImportReport(p, lensImport);
            size(f, std::move(p), catalog);
        } else {
            TomlDocument lensDoc = TomlDocument::fromFile(lensPath);
            for (const SceneEdit& e : lensEdits) applyEdit(lensDoc, e);
            Prescription p = readTomlPrescription(lensDoc, catalog);
            lensDoc.checkAllUsed();
            size(f, std::move(p), catalog);
        }
    } else {
        Prescription p = readTomlPrescription(doc, catalog);
        if (imported) keepImportReport(p, *imported);
        size(f, std::move(p), catalog);
    }
    // A misspelt key explains more than the validation error it may cause in a later
    // section (a default used in its place): on any error, unknown keys are reported first.
    try {
        f.mechanics = readMechanics(doc);
        f.meshes = readMeshImports(doc);
        f.sources = readSources(doc, f.prescription, *f.model);
        f.detectors = readDetectors(doc);
        f.properties = PropertyTable::read(doc);
        if (imported || (lens && lowerExtension(lens->asString()) != ".toml"))
            dropUnknownCoatings(f);
        f.properties.checkScatterEnergy(*f.model);
    } catch (const std::exception&) {
        doc.checkUsedInOpenedTables();
        throw;
    }
    doc.checkAllUsed();
    return f;
}

}  // namespace

}  // namespace veil
