#include "cfuse/vision/depth_file.h"

#include <fmt/format.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

// Depths (0: none) as rows of `width`, each deprojected through `intrinsics` (RealSense's model:
// the distortion applied to the pixel's normalised coordinates) and moved by `grey_from_depth`.
DepthFrame Deproject(const std::uint16_t* raw, int width, int height,
                     const DepthIntrinsics& intrinsics, double metres_per_unit,
                     const Rigid3d& grey_from_depth) {
  DepthFrame frame;
  frame.width = width;
  frame.height = height;
  frame.points.resize(static_cast<size_t>(width) * height, Eigen::Vector3f::Zero());
  const std::array<double, 5>& k = intrinsics.coefficients;
  for (int i = 0; i < height; ++i) {
    for (int j = 0; j < width; ++j) {
      const std::uint16_t d = raw[static_cast<size_t>(i) * width + j];
      if (d == 0) continue;
      const double x = (j - intrinsics.cx) / intrinsics.fx, y = (i - intrinsics.cy) / intrinsics.fy;
      const double r2 = x * x + y * y;
      const double f = 1 + k[0] * r2 + k[1] * r2 * r2 + k[4] * r2 * r2 * r2;
      const double ux = x * f + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x);
      const double uy = y * f + 2 * k[3] * x * y + k[2] * (r2 + 2 * y * y);
      const double depth = d * metres_per_unit;
      frame.points[static_cast<size_t>(i) * width + j] =
          (grey_from_depth * Eigen::Vector3d(depth * ux, depth * uy, depth)).cast<float>();
    }
  }
  return frame;
}

}  // namespace

DepthIntrinsics CastelDepthIntrinsics() {
  DepthIntrinsics sr300;
  sr300.fx = 476.053619;
  sr300.fy = 476.053497;
  sr300.cx = 311.484558;
  sr300.cy = 246.283234;
  sr300.coefficients = {0.165056542, -0.0508309528, 0.00435937941, 0.00541406544, 0.250085592};
  return sr300;
}

DepthFrame ReadRawDepth(const std::string& path, const DepthIntrinsics& intrinsics,
                        double metres_per_unit, const Rigid3d& grey_from_depth) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(SourceLocation(path), "cannot open the depth file");
  std::uint32_t header[2] = {0, 0};  // height, width
  in.read(reinterpret_cast<char*>(header), sizeof header);
  const std::uint32_t height = header[0], width = header[1];
  // (a header's sizes beyond any sensor's are a file of another kind)
  if (!in || width == 0 || height == 0 || width > 16384 || height > 16384) {
    throw InputError(SourceLocation(path, 0, 0, "header"),
                     "not a raw depth file (uint32 height and width, then uint16 depths)");
  }
  std::vector<std::uint16_t> raw(static_cast<size_t>(width) * height);
  in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size() * 2));
  if (!in) {
    throw InputError(SourceLocation(path),
                     fmt::format("the file ends before its {} x {} depths", width, height));
  }
  return Deproject(raw.data(), static_cast<int>(width), static_cast<int>(height), intrinsics,
                   metres_per_unit, grey_from_depth);
}

DepthFrame ReadDepthFrame(const std::string& path, const DepthIntrinsics& intrinsics,
                          double metres_per_unit, const Rigid3d& grey_from_depth) {
  if (std::filesystem::path(path).extension() == ".bin") {
    return ReadRawDepth(path, intrinsics, metres_per_unit, grey_from_depth);
  }
  if (!std::ifstream(path, std::ios::binary)) {
    throw InputError(SourceLocation(path), "cannot open the depth file");
  }
  const cv::Mat image = cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  if (image.empty()) {
    throw InputError(SourceLocation(path), "cannot read the depth image (no decoder for it?)");
  }
  if (image.type() != CV_16UC1) {
    throw InputError(SourceLocation(path),
                     fmt::format("not a depth image: {} bits a pixel, 16 needed",
                                 8 * static_cast<int>(image.elemSize1())));
  }
  const cv::Mat dense = image.isContinuous() ? image : image.clone();
  return Deproject(dense.ptr<std::uint16_t>(), dense.cols, dense.rows, intrinsics, metres_per_unit,
                   grey_from_depth);
}

}  // namespace cfuse
