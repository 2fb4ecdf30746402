#pragma once
// veil's native lens format: the [system] table of a TOML scene or lens file.
//
//   [system]
//   name = "Cooke triplet"
//   wavelengths_nm = [486.13, 587.56, 656.27]
//   aperture = { f_number = 4.5 }
//   fields_deg = [0.0, 14.0, 20.0]
//   surfaces = [
//     { r = 21.48, t = 2.0, glass = "N-SK16", sd = 6.5 },    # surface 1
//     { r = -124.1, t = 5.26, sd = 6.5 },                   # surface 2, air after it
//     ...                                                   # last row: t = distance to image
//   ]
//
// One inline table per surface, like the rows of a lens data editor; surface 0 (the object)
// and the image surface are implicit, unless a last row { image = true, ... } describes the
// image surface. docs/format.md documents every key, its type, default and unit.

#include <filesystem>
#include <string>
#include <string_view>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_document.h"

namespace veil {

// Reads the lens from the [system] table of `doc`, marking the keys it reads as used (other
// sections are left to their own readers; call doc.checkAllUsed() when all are done). Catalog
// glasses are looked up in `catalog`, searching system.glass_catalogs first. Surfaces get
// their stable names (Prescription::assignNames) and the result is validated.
// Throws ParseError at the value at fault, or ModelError naming the surface when the lens
// parses but Prescription::validate() rejects it.
Prescription readTomlPrescription(TomlDocument& doc, const GlassCatalog& catalog);

// A lens file: reads `path`, then rejects any key the lens reader did not use
// (TomlDocument::checkAllUsed) before the model checks.
Prescription readTomlPrescriptionFile(const std::filesystem::path& path,
                                      const GlassCatalog& catalog);
// Same from text in memory; `fileName` names it in errors and in Prescription::sourceFile.
Prescription readTomlPrescriptionText(std::string_view text, const std::string& fileName,
                                      const GlassCatalog& catalog);

}  // namespace veil
