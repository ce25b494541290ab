// Fuzz target: pose files (`--guess`, `--pose`, `--init`): the results format and ViSP's `.pos`
// (cfuse/importers/visp.h); and joint-value files (`fk --joints`). An accepted ViSP pose must be a
// rigid transform: finite, its rotation a unit quaternion.
#include <cmath>

#include "cfuse/dsl/pose_reader.h"
#include "cfuse/importers/visp.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  const std::string_view text = fuzz::AsText(data, size);
  fuzz::AcceptedOrRefused([&] { (void)ReadPosesFromString(text, "fuzz.json"); });
  fuzz::AcceptedOrRefused([&] { (void)ReadJointValuesFromString(text, "fuzz.json"); });
  fuzz::AcceptedOrRefused([&] {
    const Rigid3d pose = ReadVispPoseFromString(text, "fuzz.pos");
    if (!pose.translation.allFinite() || !pose.rotation.coeffs().allFinite() ||
        std::abs(pose.rotation.norm() - 1) > 1e-9) {
      fuzz::Finding("accepted ViSP pose", "not a rigid transform");
    }
  });
  return 0;
}
