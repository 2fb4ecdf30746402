#pragma once
// Zemax OpticStudio .zmx import (sequential lens files).
//
// A .zmx file is a line-oriented text file: a header of four-letter commands (NAME, UNIT,
// FNUM, FTYP, WAVM, ...) followed by one block per surface that starts with `SURF n`. The
// reader turns it into a Prescription: surface 0 is the object, the last SURF the image.
// Lengths are converted from the file's lens units (UNIT MM, CM, IN, METER) to mm, and the
// Zemax sign conventions are kept as they are (thickness after a mirror is negative).
//
// Nothing is dropped silently: every command the reader does not import, every glass the
// catalog does not know and every unsupported surface type (COORDBRK, TOROIDAL, ...) is listed
// in Prescription::report with its file:line and a severity:
//   Info     recognized display, solve or analysis data that does not change the optics
//            (one note per command tag, with the number of lines skipped);
//   Warning  data that changes the optics and was approximated or not imported (unknown
//            commands, unknown glass replaced by the model glass stored in the file, object-
//            space telecentricity, non-default environment, several configurations, ...);
//   Error    data the prescription cannot represent (unsupported surface types, which are kept
//            as STANDARD surfaces so the file still loads; image-height field types; non-
//            sequential mode; unknown glass without a usable model).
// Malformed numbers and a file with no SURF line throw ParseError with file:line:col.
// docs/zmx-import.md lists every command and how it maps.
//
// Encodings: ASCII / UTF-8 (with or without BOM), UTF-16 LE (with BOM, or detected by the
// pattern of NUL bytes), UTF-16 BE (with BOM, or detected the same way). Text that is not valid
// UTF-8 is read as Latin-1. Columns in error positions count characters, not bytes.

#include <filesystem>
#include <string>
#include <string_view>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"

namespace veil {

// Reads a .zmx file. Catalog glasses are looked up in `catalog`, searching the file's GCAT
// catalogs first. Throws ParseError for unreadable or malformed input and ModelError when the
// imported prescription fails Prescription::validate().
Prescription readZmx(const std::filesystem::path& path, const GlassCatalog& catalog);

// Same from the raw bytes of a file already in memory; `fileName` names it in FileLoc and
// becomes Prescription::sourceFile.
Prescription readZmxText(std::string_view bytes, const std::string& fileName,
                         const GlassCatalog& catalog);

}  // namespace veil
