// Raw depth files as ViSP's RGB-D examples record them (cfuse/vision/depth_file.h).
#include "cfuse/vision/depth_file.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

struct TempFile {
  explicit TempFile(const std::string& extension = ".bin") {
    std::random_device rd;
    path =
        (fs::temp_directory_path() / ("cfuse_depth_" + std::to_string(rd()) + extension)).string();
  }
  ~TempFile() {
    std::error_code ec;
    fs::remove(path, ec);
  }
  // A header and `depths` (fewer than it says, for a truncated file).
  void Write(std::uint32_t height, std::uint32_t width,
             const std::vector<std::uint16_t>& depths) const {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(&height), 4);
    out.write(reinterpret_cast<const char*>(&width), 4);
    out.write(reinterpret_cast<const char*>(depths.data()),
              static_cast<std::streamsize>(depths.size() * 2));
  }
  std::string path;
};

DepthIntrinsics Pinhole() {
  DepthIntrinsics k;
  k.fx = 100;
  k.fy = 50;
  k.cx = 1;
  k.cy = 0.5;
  return k;
}

TEST_CASE("depth file: depths deprojected and moved into the grey camera's frame", "[depth]") {
  const TempFile file;
  // 2 rows of 3; the middle of the first row has no depth.
  file.Write(2, 3, {1000, 0, 2000, 500, 1500, 3000});
  const Rigid3d grey_from_depth(
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(0.1, 0, 0));
  const DepthFrame plain = ReadRawDepth(file.path, Pinhole(), 0.001, Rigid3d());
  REQUIRE(plain.width == 3);
  REQUIRE(plain.height == 2);
  REQUIRE(plain.points.size() == 6);
  // Pixel (column 2, row 1): 3 m at ((2 - 1) / 100, (1 - 0.5) / 50) on the plane z = 1.
  CHECK(plain.points[5].cast<double>().isApprox(Eigen::Vector3d(0.03, 0.03, 3), 1e-6));
  CHECK(plain.points[1].isZero());
  // Moved: x' = -y + 0.1, y' = x.
  const DepthFrame moved = ReadRawDepth(file.path, Pinhole(), 0.001, grey_from_depth);
  CHECK(moved.points[5].cast<double>().isApprox(Eigen::Vector3d(0.07, 0.03, 3), 1e-6));
  CHECK(moved.points[1].isZero());
  // RealSense's distortion: k1 scales the normalised coordinates by 1 + k1 r².
  DepthIntrinsics bent = Pinhole();
  bent.coefficients[0] = 0.5;
  const DepthFrame distorted = ReadRawDepth(file.path, bent, 0.001, Rigid3d());
  const double r2 = 0.01 * 0.01 + 0.01 * 0.01;
  CHECK(distorted.points[5].x() == Approx(0.03 * (1 + 0.5 * r2)));
  CHECK(distorted.points[5].z() == Approx(3));
}

TEST_CASE("depth file: a missing, foreign or truncated file named in the error", "[depth]") {
  const TempFile file;
  auto message = [&] {
    try {
      ReadRawDepth(file.path, Pinhole(), 0.001, Rigid3d());
    } catch (const InputError& e) {
      CHECK(e.where().file == file.path);
      return e.message();
    }
    return std::string("no error");
  };
  CHECK(message() == "cannot open the depth file");
  file.Write(0, 3, {});
  CHECK(message() == "not a raw depth file (uint32 height and width, then uint16 depths)");
  file.Write(70000, 3, {});
  CHECK(message() == "not a raw depth file (uint32 height and width, then uint16 depths)");
  file.Write(2, 3, {1, 2, 3, 4, 5});
  CHECK(message() == "the file ends before its 3 x 2 depths");
}

TEST_CASE("depth file: a 16-bit image read as the raw file is", "[depth]") {
  const TempFile raw, png(".png"), grey(".png"), junk(".png");
  const std::vector<std::uint16_t> depths = {1000, 0, 2000, 500, 1500, 3000};
  raw.Write(2, 3, depths);
  cv::Mat image(2, 3, CV_16UC1);
  for (int i = 0; i < 6; ++i) image.at<std::uint16_t>(i / 3, i % 3) = depths[i];
  REQUIRE(cv::imwrite(png.path, image));
  const DepthFrame a = ReadDepthFrame(raw.path, Pinhole(), 0.001, Rigid3d());
  const DepthFrame b = ReadDepthFrame(png.path, Pinhole(), 0.001, Rigid3d());
  REQUIRE(b.points.size() == a.points.size());
  for (size_t i = 0; i < a.points.size(); ++i) CHECK(a.points[i] == b.points[i]);
  // An 8-bit picture is no depth image; a file no decoder reads is said to be so.
  REQUIRE(cv::imwrite(grey.path, cv::Mat(2, 3, CV_8UC1, cv::Scalar(7))));
  auto message = [](const std::string& path) {
    try {
      ReadDepthFrame(path, Pinhole(), 0.001, Rigid3d());
    } catch (const InputError& e) {
      CHECK(e.where().file == path);
      return e.message();
    }
    return std::string("no error");
  };
  CHECK(message(grey.path) == "not a depth image: 8 bits a pixel, 16 needed");
  std::ofstream(junk.path) << "not an image";
  CHECK(message(junk.path) == "cannot read the depth image (no decoder for it?)");
  CHECK(message(junk.path + ".missing") == "cannot open the depth file");
}

}  // namespace
}  // namespace cfuse
