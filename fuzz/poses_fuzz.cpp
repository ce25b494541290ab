// Fuzz target: pose files (`--guess`, `--pose`, `--init`) and joint-value files (`fk --joints`).
#include "dsl/pose_reader.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  const std::string_view text = fuzz::AsText(data, size);
  fuzz::AcceptedOrRefused([&] { (void)dsl::ReadPosesFromString(text, "fuzz.json"); });
  fuzz::AcceptedOrRefused([&] { (void)dsl::ReadJointValuesFromString(text, "fuzz.json"); });
  return 0;
}
