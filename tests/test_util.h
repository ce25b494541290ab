// Helpers shared by the tests.
#pragma once

#include <cstdlib>
#include <string>

namespace cfuse::testing {

// The repository root (set by ctest; tests also run from it).
inline std::string SourceDir() {
  const char* dir = std::getenv("CFUSE_SOURCE_DIR");
  return dir ? dir : ".";
}

inline std::string SourcePath(const std::string& relative) { return SourceDir() + "/" + relative; }

}  // namespace cfuse::testing
