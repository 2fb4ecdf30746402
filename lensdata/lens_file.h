#pragma once
// Reads a lens file of any supported format, chosen by extension: .toml (veil scene or lens
// file) or .zmx (Zemax OpticStudio). Errors are ParseError (file:line:col) or ModelError.

#include <filesystem>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"

namespace veil {

Prescription readLensFile(const std::filesystem::path& path, const GlassCatalog& catalog);

}  // namespace veil
