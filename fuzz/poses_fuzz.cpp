// Fuzz target: pose files (`--guess`, `--pose`, `--init`, `--depth-pose`): the results format,
// ViSP's `.pos` and its homogeneous matrices (cfuse/importers/visp.h); and joint-value files
// (`fk --joints`). An accepted ViSP pose must be a rigid transform: finite, its rotation a unit
// quaternion.
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
  auto rigid = [](const Rigid3d& pose, const char* what) {
    if (!pose.translation.allFinite() || !pose.rotation.coeffs().allFinite() ||
        std::abs(pose.rotation.norm() - 1) > 1e-9) {
      fuzz::Finding(what, "not a rigid transform");
    }
  };
  fuzz::AcceptedOrRefused(
      [&] { rigid(ReadVispPoseFromString(text, "fuzz.pos"), "accepted ViSP pose"); });
  fuzz::AcceptedOrRefused(
      [&] { rigid(ReadVispMatrixPoseFromString(text, "fuzz.txt"), "accepted ViSP matrix"); });
  return 0;
}
