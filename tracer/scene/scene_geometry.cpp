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

SceneGeometry buildSceneGeometry(const SceneSpec& file, const GlassCatalog& catalog,
                                 const SceneOptions& options) {
    SceneGeometry s;
    s.model = file.model ? file.model
                         : std::make_shared<const SequentialModel>(
                               SequentialModel::build(file.prescription, catalog));
    const SequentialModel& model = *s.model;
    s.prescription = file.prescription;
    s.notes = s.prescription.report;
    const Prescription& p = s.prescription;

    LensSolidOptions lensOptions;
    if (options.mechanics && file.mechanics && !file.mechanics->lensEdgeProperty.empty()) {
        lensOptions.edgeProperty = file.mechanics->lensEdgeProperty;
        lensOptions.flatProperty = file.mechanics->lensEdgeProperty;
    }
    addLensSolids(p, s.scene, lensOptions);

    if (options.mechanics && file.mechanics) {
        std::vector<std::string> left;
        s.mechanicalParts = buildMechanics(p, *file.mechanics, &left);
        for (const std::string& n : left) {
            ImportNote note;
            note.severity = ImportNote::Severity::Info;
            note.loc.file = file.path.string();
            note.message = n;
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
    // Large enough for the image circle and for every detector rectangle placed on it.
    double sensorRadius = is.clearSemiDiameterMm;
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
