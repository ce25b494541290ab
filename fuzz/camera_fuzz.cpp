// Fuzz target: camera files, all of their formats: cfuse's own and ROS camera_info (YAML, read by
// dsl/) and OpenCV's calibration files (YAML, XML, JSON, read by cv::FileStorage in vision/).
// OpenCV's own parser is not instrumented, so inside it only crashes count, not coverage.
#include "dsl/measurement_reader.h"
#include "fuzz/fuzz_util.h"
#include "vision/camera_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  const std::string_view text = fuzz::AsText(data, size);
  fuzz::AcceptedOrRefused([&] { (void)dsl::ReadCameraFromString(text, "fuzz.yaml"); });
  fuzz::AcceptedOrRefused([&] { (void)vision::ReadOpenCvCameraFromString(text, "fuzz.yml"); });
  return 0;
}
