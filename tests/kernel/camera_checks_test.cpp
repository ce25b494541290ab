// The checks every camera reader applies (kernel/src/measurements/camera_checks.cpp): each
// problem of a camera matrix, a distortion list and a principal point, at its entry and in the
// readers' shared words, with the tolerances at their edges; and the camera built from checked
// values.
#include "cfuse/kernel/measurements/camera_checks.h"

#include <fmt/format.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// K with entry i set to v.
std::vector<double> K(int i = -1, double v = 0) {
  std::vector<double> k = {800, 0, 320, 0, 700, 240, 0, 0, 1};
  if (i >= 0) k[i] = v;
  return k;
}

void ExpectProblem(const std::optional<CameraProblem>& p, int index, const std::string& message) {
  REQUIRE(p.has_value());
  CHECK(p->index == index);
  CHECK(p->message == message);
}

TEST_CASE("camera checks: a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1]", "[kernel]") {
  CHECK_FALSE(CameraMatrixProblem(K()));
  ExpectProblem(CameraMatrixProblem(K(4, std::nan(""))), 4, "K[1][1] must be finite, got nan");
  // OpenCV reads `.Nan` as -nan: said the same way.
  ExpectProblem(CameraMatrixProblem(K(2, -std::nan(""))), 2, "K[0][2] must be finite, got nan");
  ExpectProblem(CameraMatrixProblem(K(7, -kInf)), 7, "K[2][1] must be finite, got -inf");
  // Finiteness first, wherever the entry.
  std::vector<double> both = K(0, -1);
  both[8] = kInf;
  ExpectProblem(CameraMatrixProblem(both), 8, "K[2][2] must be finite, got inf");
  ExpectProblem(CameraMatrixProblem(K(0, 0)), 0, "fx = K[0][0] must be positive, got 0");
  ExpectProblem(CameraMatrixProblem(K(4, -700)), 4, "fy = K[1][1] must be positive, got -700");
  // The skew and the zeros are zero to 1e-9, relative to fx and fy for the first row's and the
  // second row's, absolute in the last.
  CHECK_FALSE(CameraMatrixProblem(K(1, 7.9e-7)));
  ExpectProblem(CameraMatrixProblem(K(1, 8.1e-7)), 1,
                "the skew K[0][1] must be 0, got 8.1e-07: cfuse's camera has no skew term");
  CHECK_FALSE(CameraMatrixProblem(K(3, -6.9e-7)));
  ExpectProblem(CameraMatrixProblem(K(3, 7.5e-7)), 3,  // below fx's tolerance, above fy's
                "K[1][0] must be 0, got 7.5e-07: a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1]");
  CHECK_FALSE(CameraMatrixProblem(K(6, 1e-9)));
  ExpectProblem(CameraMatrixProblem(K(6, 2e-9)), 6,
                "K[2][0] must be 0, got 2e-09: a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1]");
  CHECK_FALSE(CameraMatrixProblem(K(8, 1 + 5e-10)));
  ExpectProblem(CameraMatrixProblem(K(8, 2)), 8,
                "K[2][2] must be 1, got 2: a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1]");
  CHECK_THROWS_AS(CameraMatrixProblem(std::vector<double>(8, 1.0)), InternalError);
}

TEST_CASE("camera checks: OpenCV's distortion lists, finite and without tilt", "[kernel]") {
  for (size_t n : {0, 4, 5, 8, 12, 14}) {
    std::vector<double> d(n, 0.01);
    if (n == 14) d[12] = d[13] = 0;
    INFO(n << " coefficients");
    CHECK_FALSE(DistortionProblem(d));
  }
  for (size_t n : {1, 3, 6, 13, 15}) {
    INFO(n << " coefficients");
    ExpectProblem(DistortionProblem(std::vector<double>(n, 0.0)), -1,
                  fmt::format("has {} coefficients; OpenCV's model takes 4, 5, 8, 12 or 14 (k1 k2 "
                              "p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tau_x tau_y]]]])",
                              n));
  }
  ExpectProblem(DistortionProblem(std::vector<double>{0.1, 0, std::nan(""), 0}), 2,
                "coefficient 3 (p1) must be finite, got nan");
  ExpectProblem(DistortionProblem(std::vector<double>{0, 0, 0, 0, 0, 0, 0, -kInf}), 7,
                "coefficient 8 (k6) must be finite, got -inf");
  std::vector<double> tilted(14, 0.0);
  tilted[13] = 0.1;
  ExpectProblem(DistortionProblem(tilted), 13,
                "has the tilted-sensor coefficients tau_x = 0, tau_y = 0.1 (13th and 14th): "
                "cfuse's camera has no tilt, they must be 0");
  tilted[12] = -0.2;
  CHECK(DistortionProblem(tilted)->index == 12);

  const char* names[] = {"k1", "k2", "p1", "p2", "k3", "k4",    "k5",
                         "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y"};
  for (int i = 0; i < 14; ++i) CHECK(std::string(DistortionName(i)) == names[i]);
  CHECK_THROWS_AS(DistortionName(14), InternalError);
  CHECK_THROWS_AS(DistortionName(-1), InternalError);
}

TEST_CASE("camera checks: the principal point within a whole image, and image sides", "[kernel]") {
  CHECK_FALSE(PrincipalPointProblem(320, 240, 640, 480));
  CHECK_FALSE(PrincipalPointProblem(-640, 960, 640, 480));  // the bounds are inside
  ExpectProblem(PrincipalPointProblem(1280.5, 240, 640, 480), 0,
                "the principal point cx = 1280.5 is outside [-640, 1280], a whole image beyond "
                "the 640 x 480 image: is the camera matrix for another image size?");
  ExpectProblem(PrincipalPointProblem(320, -481, 640, 480), 1,
                "the principal point cy = -481 is outside [-480, 960], a whole image beyond the "
                "640 x 480 image: is the camera matrix for another image size?");
  CHECK(PrincipalPointProblem(std::nan(""), 240, 640, 480)->index == 0);
  CHECK_THROWS_AS(PrincipalPointProblem(0, 0, 0, 480), InternalError);

  for (double ok : {1.0, 640.0, 1e6}) CHECK(IsImageSide(ok));
  for (double bad : {0.0, -3.0, 0.5, 640.5, 1e6 + 1, std::nan(""), kInf}) {
    CHECK_FALSE(IsImageSide(bad));
  }
}

TEST_CASE("camera checks: the pinhole camera of checked values", "[kernel]") {
  std::vector<double> d(14);
  for (int i = 0; i < 12; ++i) d[i] = 0.01 * (i + 1);
  const Camera c = PinholeCamera(K(), d, 640, 480);
  CHECK(c.model == Camera::Model::kPinhole);
  CHECK(c.fx == 800);
  CHECK(c.fy == 700);
  CHECK(c.cx == 320);
  CHECK(c.cy == 240);
  CHECK(c.width == 640);
  CHECK(c.height == 480);
  for (int i = 0; i < 12; ++i) CHECK(c.distortion[i] == d[i]);
  // Five coefficients: the rest zero.
  const Camera five =
      PinholeCamera(K(), std::vector<double>{0.1, -0.2, 0.001, 0.002, 0.05}, 640, 480);
  CHECK(five.distortion[4] == 0.05);
  for (int i = 5; i < 12; ++i) CHECK(five.distortion[i] == 0);
  // Unchecked values break the contract.
  CHECK_THROWS_AS(PinholeCamera(K(1, 3), {}, 640, 480), InternalError);
  CHECK_THROWS_AS(PinholeCamera(K(), std::vector<double>(3), 640, 480), InternalError);
  CHECK_THROWS_AS(PinholeCamera(K(2, 5000), {}, 640, 480), InternalError);
}

}  // namespace
}  // namespace cfuse
