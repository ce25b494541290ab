// Fuzz target: ViSP CAO import (points, lines, faces, load() of other files).
#include "cfuse/importers/cao.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  static const std::string base = CFUSE_FUZZ_SOURCE_DIR "/tests/data/cao";
  fuzz::AcceptedOrRefused(
      [&] { (void)ImportCaoFromString(fuzz::AsText(data, size), "fuzz.cao", base); });
  return 0;
}
