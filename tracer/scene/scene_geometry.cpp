#include "tracer/scene/scene_geometry.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "geometry/lens_solid.h"
#include "geometry/surface_frames.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/input_file.h"
#include "lensdata/prescription.h"
#include "tracer/records/detector.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

namespace {
// An automatic image semi-diameter below this fraction of the last lens surface's clear one
// is a spot radius, not a sensor; the sensor then gets kSensorFloorFraction of it.
constexpr double kTinySensorFraction = 1e-3;
constexpr double kSensorFloorFraction = 0.1;
// How far behind the last face a sensor on that face is placed.
constexpr double kImageClearanceMm = 1e-3;

}  // namespace

SceneGeometry buildSceneGeometry(const SceneSpec& file, const GlassCatalog& catalog,
                                 const SceneOptions& options) {
    if (file.sizeError) throw *file.sizeError;
    SceneGeometry s;
    s.model = file.model ? file.model
                         : std::make_shared<const SequentialModel>(
                               SequentialModel::build(file.prescription, catalog));
    const SequentialModel& model = *s.model;
    s.prescription = file.prescription;
    s.notes = s.prescription.report;
    const Prescription& p = s.prescription;
    // The solids and mounts: mirrors with the holes the light comes back through.
    Prescription solids = p;
    for (size_t i = 0; i < file.mirrorHoles.size() && i < solids.surfaces.size(); ++i)
        if (file.mirrorHoles[i] > 0.0) solids.surfaces[i].innerSemiDiameterMm = file.mirrorHoles[i];

    LensSolidOptions lensOptions;
    if (options.mechanics && file.mechanics && !file.mechanics->lensEdgeProperty.empty()) {
        lensOptions.edgeProperty = file.mechanics->lensEdgeProperty;
        lensOptions.flatProperty = file.mechanics->lensEdgeProperty;
    }
    {
        Prescription immersed = solids;
        immersed.assignNames();
        const int added = endImmersedImage(immersed);
        if (added >= 0) {
            const Surface& medium = immersed.surfaces[added - 1];
            ImportNote note;
            note.severity = ImportNote::Severity::Info;
            note.loc = p.surfaces[p.imageIndex()].origin;
            note.message = "the image lies inside the glass after " + medium.name + " (" +
                           medium.material.label() + "): " + immersed.surfaces[added].name +
                           ", where that medium ends, is placed " +
                           messageNumber(kImmersedImageClearanceMm) +
                           " mm behind the image, so that the sensor lies inside the medium "
                           "and meets the light as it arrives there";
            s.notes.push_back(std::move(note));
        }
    }
    addLensSolids(solids, s.scene, lensOptions);

    if (options.mechanics && file.mechanics) {
        std::vector<std::string> left;
        s.mechanicalParts = buildMechanics(solids, *file.mechanics, &left);
        for (const std::string& n : left) {
            ImportNote note;
            const bool warning = n.rfind(kMechanicsWarning, 0) == 0;
            note.severity = warning ? ImportNote::Severity::Warning : ImportNote::Severity::Info;
            note.loc.file = file.path.string();
            note.message = warning ? n.substr(kMechanicsWarning.size()) : n;
            s.notes.push_back(std::move(note));
        }
        for (const MechanicalPart& part : s.mechanicalParts) {
            const int mesh = s.scene.addMesh(part.mesh);
            for (const NamedTriangleRange& r : part.namedRanges) {
                SceneObject o;
                o.name = r.name;
                o.kind = r.name.rfind("stop", 0) == 0 ? ObjectKind::Stop : ObjectKind::Mechanics;
                o.part = part.name;
                o.property = r.property;
                o.geometry = MeshRef{mesh, r.firstTriangle, r.triangleCount};
                s.scene.addObject(std::move(o));
            }
        }
    }
    if (options.meshes) {
        for (const MeshImportSpec& spec : file.meshes) {
            ImportedMesh im = loadMeshImport(spec);
            s.notes.insert(s.notes.end(), im.notes.begin(), im.notes.end());
            const uint32_t count = static_cast<uint32_t>(im.mesh.triangles.size());
            const int mesh = s.scene.addMesh(std::move(im.mesh));
            SceneObject o;
            o.name = im.name;
            o.kind = ObjectKind::ImportedMesh;
            o.part = im.name;
            o.property = im.property;
            o.geometry = MeshRef{mesh, 0, count};
            s.scene.addObject(std::move(o));
        }
    }

    // The image surface is the detector: its shape, the traced image semi-diameter.
    const int image = model.imageIndex();
    const Surface& is = p.surfaces[image];
    SceneObject det;
    det.name = "sensor";
    det.aliases = {"image"};
    det.kind = ObjectKind::Detector;
    det.part = "sensor";
    det.frame = model.surface(image).frame;
    // An image on the last face itself (no gap) would be met by no ray leaving that face, which
    // starts on it: the sensor moves kImageClearanceMm on, the way the light goes.
    if (image >= 2 && p.surfaces[image - 1].thicknessMm == 0.0 &&
        !p.surfaces[image - 1].coordinateBreak) {
        double direction = 1.0;
        for (int i = 1; i < image; ++i)
            if (p.surfaces[i].mirror) direction = -direction;
        det.frame.translation += det.frame.rotation * Vec3(0.0, 0.0, direction * kImageClearanceMm);
        ImportNote note;
        note.severity = ImportNote::Severity::Info;
        note.loc = is.origin;
        note.message = "the image lies on " + p.surfaces[image - 1].name +
                       " itself: the sensor is placed " + messageNumber(kImageClearanceMm) +
                       " mm behind it, where the light leaving that face can reach it";
        s.notes.push_back(std::move(note));
    }
    // Large enough for the image circle and for every detector rectangle placed on it. An
    // image semi-diameter a program computed for a single on-axis field is the spot's radius,
    // micrometres or less: a sensor of that size records nothing of a scene's light. It gets a
    // tenth of the last lens surface's clear semi-diameter instead, said.
    double sensorRadius = is.clearSemiDiameterMm;
    double lastLens = 0.0;
    for (int i = image - 1; i > 0 && lastLens == 0.0; --i)
        if (!p.surfaces[i].coordinateBreak &&
            (p.surfaces[i].mirror || !p.surfaces[i].material.isAir() ||
             !p.surfaces[i - 1].material.isAir()))
            lastLens = p.surfaces[i].clearSemiDiameterMm;
    if (is.semiDiameterAutomatic && sensorRadius < kTinySensorFraction * lastLens) {
        const double given = sensorRadius;
        sensorRadius = kSensorFloorFraction * lastLens;
        ImportNote note;
        note.severity = ImportNote::Severity::Warning;
        note.loc = is.origin;
        note.message = "the image surface's semi-diameter " + messageNumber(given) +
                       " mm (computed for the file's fields) would make a sensor that records "
                       "nothing; the sensor is " +
                       messageNumber(sensorRadius) +
                       " mm in radius, a tenth of the last lens surface's; give the detector its "
                       "size with [detector] size_mm";
        s.notes.push_back(std::move(note));
    }
    for (const DetectorSpec& d : file.detectors)
        if ((d.object.empty() || d.object == "sensor" || d.object == "image") && !d.zMm && d.sizeMm)
            sensorRadius =
                std::max(sensorRadius, std::hypot(0.5 * d.sizeMm->x + std::abs(d.centerMm.x),
                                                  0.5 * d.sizeMm->y + std::abs(d.centerMm.y)));
    det.geometry = FaceGeometry{SurfacePatch{surfaceShape(is), CircularAperture{sensorRadius}}};
    det.sequentialSurface = image;
    s.scene.addObject(std::move(det));
    // Detectors: on scene objects (the sensor by default) or free rectangles of their own.
    std::vector<DetectorSpec> specs = file.detectors;
    if (specs.empty()) specs.push_back(DetectorSpec{});
    s.detectors = placeDetectors(specs, s.scene);
    for (DetectorGeometry& g : s.detectors)
        if (g.object < 0) g.object = s.scene.addObject(detectorSceneObject(g));
    s.scene.commit();
    return s;
}

}  // namespace veil
