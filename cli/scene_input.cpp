// What every command that reads a scene shares: the glass catalogs, the --set edits, the
// scene's notes on standard error, and the scene of a command that traces (--field beams, or
// one beam per system field for a file without sources).

#include <algorithm>
#include <iostream>
#include <sstream>
#include <tuple>

#include "analysis/lens/default_scene.h"
#include "analysis/lens/detector_checks.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/surfaces/property_table.h"

namespace veil::cli {

GlassCatalog loadCatalog(const CommonOptions& common) {
    GlassCatalog catalog = GlassCatalog::withEnvironment();
    for (const std::string& f : common.glassCatalogs) catalog.loadAgf(f);
    return catalog;
}

std::vector<SceneEdit> sceneEdits(const CommonOptions& common) {
    std::vector<SceneEdit> edits;
    for (size_t k = 0; k < common.sets.size(); ++k) {
        const std::string& s = common.sets[k];
        const size_t eq = s.find('=');
        if (eq == std::string::npos || eq == 0)
            throw ParseError({"--set " + s, 0, 0},
                             "expected KEY=VALUE, as in properties.black.scatter.reflectance=0.02");
        edits.push_back({s.substr(0, eq), s.substr(eq + 1), "--set " + s});
    }
    return edits;
}

SceneSpec readScene(const CommonOptions& common, const std::string& path,
                    const GlassCatalog& catalog) {
    return readSceneFile(path, catalog, sceneEdits(common));
}

std::unique_ptr<tbb::global_control> limitThreads(int threads) {
    if (threads <= 0) return nullptr;
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                 static_cast<size_t>(threads));
}

std::vector<std::string> importNoteLines(const std::vector<ImportNote>& notes) {
    using Severity = ImportNote::Severity;
    using Topic = ImportNote::Topic;
    std::vector<const ImportNote*> glassNotes, unknown;
    std::vector<std::string> other;
    auto text = [](const ImportNote& n) {
        std::ostringstream os;
        if (n.severity == Severity::Info) {
            os << n.loc << ": note: " << n.message;
        } else {
            os << n;
        }
        return os.str();
    };
    for (const ImportNote& n : notes) {
        if (n.topic == Topic::UnknownCommand && n.severity == Severity::Warning) {
            unknown.push_back(&n);
            continue;
        }
        // The glass a legacy name denotes is a substitution the user should see; other
        // infos stay in the import report (veil info).
        if (n.severity == Severity::Info && n.topic != Topic::Glass) continue;
        if (n.topic == Topic::Glass) {
            glassNotes.push_back(&n);
        } else {
            other.push_back(text(n));
        }
    }
    // The glasses in file order.
    std::stable_sort(
        glassNotes.begin(), glassNotes.end(), [](const ImportNote* a, const ImportNote* b) {
            return std::tie(a->loc.file, a->loc.line) < std::tie(b->loc.file, b->loc.line);
        });
    std::vector<std::string> lines;
    for (const ImportNote* n : glassNotes) lines.push_back(text(*n));
    lines.insert(lines.end(), other.begin(), other.end());
    if (unknown.size() == 1) {
        lines.push_back(text(*unknown.front()));
    } else if (unknown.size() > 1) {
        std::ostringstream os;
        os << unknown.front()->loc.file << ": warning: " << unknown.size()
           << " commands veil does not read were ignored: ";
        for (size_t i = 0; i < unknown.size(); ++i)
            os << (i > 0 ? ", " : "")
               << (unknown[i]->subject.empty() ? unknown[i]->message : unknown[i]->subject);
        lines.push_back(os.str());
    }
    // Each once, in that order.
    std::vector<std::string> once;
    for (std::string& l : lines)
        if (std::find(once.begin(), once.end(), l) == once.end()) once.push_back(std::move(l));
    return once;
}

std::string uncoatedFacesNote(const PreparedScene& scene) {
    const std::vector<std::string> names = scene.spec().properties.uncoatedFaces(scene.scene());
    if (names.empty()) return {};
    int faces = 0;
    for (const SceneObject& o : scene.scene().objects())
        faces += o.kind == ObjectKind::LensFace && !isCementedFace(o) ? 1 : 0;
    std::ostringstream os;
    os << names.size() << " of " << faces
       << " lens faces in air are uncoated (bare Fresnel, about 4 % reflected at n = 1.5): ";
    for (size_t i = 0; i < names.size(); ++i) os << (i > 0 ? ", " : "") << names[i];
    os << ". Coat them with [[assign]] (docs/format.md) to study the lens as built";
    return os.str();
}

void reportSceneNotes(const PreparedScene& scene) {
    std::vector<ImportNote> notes = scene.geometry().notes;
    for (ImportNote& n : detectorPlacementWarnings(scene.spec(), scene.geometry()))
        notes.push_back(std::move(n));
    for (const std::string& line : importNoteLines(notes)) std::cerr << "veil: " << line << "\n";
    const std::string uncoated = uncoatedFacesNote(scene);
    if (!uncoated.empty()) std::cerr << "veil: note: " << uncoated << "\n";
}

void reportImportWarnings(const SceneSpec& spec) {
    for (const std::string& line : importNoteLines(spec.prescription.report))
        std::cerr << "veil: " << line << "\n";
}

std::unique_ptr<PreparedScene> prepareTracedScene(const CommonOptions& common,
                                                  const std::string& path,
                                                  const std::vector<std::string>& fields,
                                                  const GlassCatalog& catalog,
                                                  const SceneOptions& options) {
    std::string note;
    std::unique_ptr<PreparedScene> scene = veil::prepareTracedScene(
        readScene(common, path, catalog), catalog, parseFields(fields), options, &note);
    if (!note.empty()) std::cerr << "veil: note: " << note << "\n";
    return scene;
}

}  // namespace veil::cli
