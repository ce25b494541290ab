// Reading an imported file's bytes with located errors (internal to importers/): a missing file
// is reported where it was named (an include's line) when that is known, a directory, an
// unreadable file and one over the format's size limit at the file; binary data is refused.
#pragma once

#include <cstddef>
#include <string>

#include "cfuse/kernel/error.h"

namespace cfuse {

// `format` names the file in messages ("CAO", "URDF").
std::string ReadImportedFile(const std::string& path, const SourceLocation& named_at,
                             const char* format, size_t max_bytes);

}  // namespace cfuse
