#include "lensdata/lens_file.h"

#include <algorithm>
#include <cctype>

#include "lensdata/codev_reader.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/input_file.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_reader.h"
#include "lensdata/zmx_reader.h"

namespace veil {

Prescription readLensFile(const std::filesystem::path& path, const GlassCatalog& catalog) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (!inputFileExists(path)) throw ParseError({path.string(), 0, 0}, "no such file");
    if (ext == ".zmx") return readZmx(path, catalog);
    if (ext == ".toml") return readTomlPrescriptionFile(path, catalog);
    if (ext == ".seq") return readCodeV(path, catalog);
    throw ParseError({path.string(), 0, 0},
                     "unknown lens file type '" + ext + "' (expected .toml, .zmx or .seq)");
}

}  // namespace veil
