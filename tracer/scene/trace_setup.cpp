#include "tracer/scene/trace_setup.h"

namespace veil {

TraceSetup prepareTrace(const SceneFile& file, const SceneSetup& setup,
                        const GlassCatalog& catalog) {
    TraceSetup t;
    const Prescription& p = setup.prescription;
    std::vector<double> wavelengths;
    for (const Wavelength& w : p.system.wavelengths) wavelengths.push_back(w.nm);
    if (wavelengths.empty()) wavelengths.push_back(kLineD);
    t.media =
        std::make_unique<MediaOptics>(setup.scene, catalog, p.system.glassCatalogs, wavelengths);
    if (file.sources.empty())
        throw ModelError(file.path.string(), "the scene has no [[source]] to trace");
    t.transport.scene = &setup.scene;
    t.transport.media = t.media.get();
    t.transport.properties = file.properties.properties();
    t.transport.propertyOfObject = file.properties.resolve(setup.scene);
    t.transport.detectorOfObject.assign(setup.scene.objects().size(), -1);
    for (size_t d = 0; d < setup.detectors.size(); ++d) {
        t.transport.detectorOfObject[setup.detectors[d].object] = static_cast<int>(d);
        t.images.push_back(DetectorImage::grid(setup.detectors[d]));
        t.transport.detectorNames.push_back(setup.detectors[d].name);
    }
    t.transport.sources = file.sources;
    return t;
}

}  // namespace veil
