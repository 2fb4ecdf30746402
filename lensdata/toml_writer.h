#pragma once
// A prescription as a veil lens file (docs/format.md): what `veil export-lens` writes, and how
// `--set` edits an imported lens (Zemax, CODE V): the lens is written as TOML, edited there and
// read back. Every value the import kept is written: system data (aperture, fields with their
// weights and vignetting factors, wavelengths, the catalogs the lens names that veil has),
// and per surface the shape (curvature, conic, even and odd aspheres, Q-type, toroidal and
// biconic), thickness, medium (catalog glass or model nd/Vd/dPgF), semi-diameters (fixed or
// computed by the program that wrote the file), hole, stop, mirror, coating, coordinate
// breaks, names that differ from veil's own and comments. Numbers are written in the
// shortest form that reads back to the same double, so reading the text gives the same
// prescription (tests/lensdata/toml_writer_test.cpp).

#include <string>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"

namespace veil {

// `source` names where the lens came from in the file's first comment; `catalog` decides which
// of the lens's glass_catalogs to keep (a catalog veil has not loaded would be an error in a
// TOML lens). Throws ModelError naming the surface for what the format cannot hold (an object
// surface with a shape).
std::string prescriptionToml(const Prescription& lens, const GlassCatalog& catalog,
                             const std::string& source);

}  // namespace veil
