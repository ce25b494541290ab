// The contract on a measurement set built in code: image points come with a camera, and each
// point's own values (its position or pixel and their covariance) are finite.
#include "cfuse/kernel/measurement_set.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

TEST_CASE("measurement set: a set built in code keeps the contract or is refused", "[kernel]") {
  MeasurementSet set;
  set.points.resize(2);
  set.points[0].cov3 = Eigen::Matrix3d::Identity();
  set.points[1].cov3 = Eigen::Matrix3d::Identity();
  CHECK_NOTHROW(CheckMeasurementSet(set));
  set.points[1].xyz.x() = std::nan("");
  CHECK_THROWS_WITH(CheckMeasurementSet(set), Catch::Contains("measurement 1"));
  set.points[1].xyz.x() = 0;
  // An image point needs a camera.
  set.points[1].is_3d = false;
  set.points[1].cov2 = Eigen::Matrix2d::Identity();
  CHECK_THROWS_WITH(CheckMeasurementSet(set), Catch::Contains("no camera"));
  set.camera = Camera{};
  CHECK_NOTHROW(CheckMeasurementSet(set));
  set.points[1].cov2(0, 1) = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(CheckMeasurementSet(set), InternalError);
}

TEST_CASE("measurement set: only the values a point's kind uses are checked", "[kernel]") {
  CHECK_NOTHROW(CheckMeasurementSet(MeasurementSet{}));
  MeasurementSet set;
  set.camera = Camera{};
  set.points.resize(3);
  set.points[1].is_3d = false;
  // A 3D point's pixel and an image point's position are not read.
  set.points[0].uv.setConstant(std::nan(""));
  set.points[1].xyz.setConstant(std::numeric_limits<double>::infinity());
  set.points[1].cov3(2, 2) = std::nan("");
  CHECK_NOTHROW(CheckMeasurementSet(set));
  set.points[2].cov3(1, 0) = -std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH(CheckMeasurementSet(set),
                    Catch::Contains("measurement 2: a value or its covariance is not finite"));
  set.points[2].cov3(1, 0) = 0;
  set.points[1].uv.y() = std::nan("");
  CHECK_THROWS_WITH(CheckMeasurementSet(set),
                    Catch::Contains("measurement 1: a value or its covariance is not finite"));
  // Without a camera the image point is refused for that first.
  set.camera.reset();
  CHECK_THROWS_WITH(CheckMeasurementSet(set),
                    Catch::Contains("measurement 1 is an image point and the set has no camera"));
}

}  // namespace
}  // namespace cfuse
