#include "tracer/scene/scene_transport.h"

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tracer/records/detector.h"
#include "tracer/surfaces/media.h"

namespace veil {

SceneTransport prepareTransport(const SceneSpec& file, const SceneGeometry& setup,
                                const GlassCatalog& catalog) {
    SceneTransport t;
    const Prescription& p = setup.prescription;
    std::vector<double> wavelengths;
    for (const Wavelength& w : p.system.wavelengths) wavelengths.push_back(w.nm);
    if (wavelengths.empty()) wavelengths.push_back(kLineD);
    t.media =
        std::make_unique<MediaOptics>(setup.scene, catalog, p.system.glassCatalogs, wavelengths);
    if (file.sources.empty())
        throw ModelError(file.path.string(), "the scene has no [[source]] to trace");
    t.view.scene = &setup.scene;
    t.view.media = t.media.get();
    t.view.properties = file.properties.properties();
    t.view.propertyOfObject = file.properties.resolve(setup.scene);
    t.view.detectorOfObject.assign(setup.scene.objects().size(), -1);
    t.view.nextDetector.assign(setup.detectors.size(), -1);
    for (size_t d = 0; d < setup.detectors.size(); ++d) {
        int& first = t.view.detectorOfObject[setup.detectors[d].object];
        if (first < 0) {
            first = static_cast<int>(d);
        } else {
            int last = first;
            while (t.view.nextDetector[last] >= 0) last = t.view.nextDetector[last];
            t.view.nextDetector[last] = static_cast<int>(d);
        }
        t.images.push_back(DetectorImage::grid(setup.detectors[d]));
        t.view.detectorNames.push_back(setup.detectors[d].name);
    }
    t.view.sources = file.sources;
    return t;
}

}  // namespace veil
