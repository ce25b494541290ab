// Fuzz target: camera files, all of their formats: cfuse's own and ROS camera_info (YAML, read by
// dsl/), OpenCV's calibration files (YAML, XML, JSON, read by cv::FileStorage in vision/ behind
// its screen, vision/src/file_storage_screen.h) and ViSP's XML cameras (TinyXML, in importers/).
// OpenCV's and TinyXML's parsers are not instrumented, so inside them only crashes count, not
// coverage. An accepted camera must be one the projection can use.
#include <cmath>

#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/importers/visp.h"
#include "cfuse/vision/camera_file.h"
#include "fuzz/fuzz_util.h"

namespace {

void CheckUsable(const cfuse::Camera& camera) {
  if (camera.model == cfuse::Camera::Model::kPinhole &&
      !(std::isfinite(camera.fx) && std::isfinite(camera.fy) && camera.fx > 0 && camera.fy > 0 &&
        std::isfinite(camera.cx) && std::isfinite(camera.cy))) {
    cfuse::fuzz::Finding("accepted camera", "a pinhole camera without a finite, positive focus");
  }
  if (camera.width < 0 || camera.height < 0) {
    cfuse::fuzz::Finding("accepted camera", "a negative image size");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  const std::string_view text = fuzz::AsText(data, size);
  fuzz::AcceptedOrRefused([&] { CheckUsable(ReadCameraFromString(text, "fuzz.yaml")); });
  fuzz::AcceptedOrRefused(
      [&] { CheckUsable(ReadOpenCvCameraFromString(text, "fuzz.yml")); });
  fuzz::AcceptedOrRefused(
      [&] { CheckUsable(ReadVispCameraFromString(text, "fuzz.xml")); });
  return 0;
}
