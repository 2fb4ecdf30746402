#pragma once
// CODE V sequence file (.seq) import.
//
// A .seq file is a list of commands, mostly three-letter codes: `;` separates commands on a
// line, `!` starts a comment, a line ending in `&` continues on the next. System data (EPD,
// FNO, NAO, DIM, WL, REF, XAN/YAN, XOB/YOB, XIM/YIM, XRI/YRI, ...) come first; then the
// surfaces: `SO r t` (the object), `S r t [glass]` for each surface, `SI r t` (the image),
// each followed by lines that modify it (STO, CIR, ASP with K and A..J, RDY, THI, GLA, ...).
// `RDM` (radius mode, the default here) or `RDM N` (curvature mode) says how the first number
// of S, SO and SI reads. The reader turns it into a Prescription with CODE V's sign
// conventions, which are veil's (a thickness after a mirror is negative; REFL keeps the
// medium the light came from); lengths are converted from DIM units to mm.
//
// Glass: a catalog glass as CODE V writes it (NBK7_SCHOTT, SLAL8_OHARA: the name without its
// hyphens and the vendor after the last underscore; matched to the catalog ignoring case and
// punctuation, that vendor's catalog first), a bare or quoted name, a fictitious glass as a
// number (517000.520000 or 569.631: the integer digits are the decimals of nd - 1, the
// fraction x 100 is vd; a six-digit integer 517642 is the glass code nd 1.517, vd 64.2), or
// nd:vd; REFL makes the surface a mirror.
//
// Nothing is dropped silently: Prescription::report lists every command not imported with its
// file:line and a severity, as for ZMX (lensdata/zmx_reader.h): Info for data that does not
// change the optics (variable codes CCY/THC, solves PIM/PIK whose values the S lines already
// hold, labels, vignetting factors, temperature); Warning for data that changes the optics
// and was approximated or left out (an unknown command, an unknown glass replaced by a model
// glass); Error for what the prescription cannot represent (decenters and tilts, surface types
// other than sphere, conic and even asphere, private glass catalogs, zoom), which stops every
// command that builds the scene. Malformed numbers throw ParseError with file:line:col.
// docs/codev-import.md lists every command.

#include <filesystem>
#include <string>
#include <string_view>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"

namespace veil {

// Reads a .seq file. Throws ParseError for unreadable or malformed input (naming
// file:line:col) and ModelError when the prescription fails Prescription::validate().
Prescription readCodeV(const std::filesystem::path& path, const GlassCatalog& catalog);

// Same from the raw bytes of a file already in memory; `fileName` names it in FileLoc.
Prescription readCodeVText(std::string_view bytes, const std::string& fileName,
                           const GlassCatalog& catalog);

}  // namespace veil
