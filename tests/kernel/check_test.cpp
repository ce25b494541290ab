// The contract checks (error tier 2): a failed check throws InternalError naming the condition
// and, for a comparison, both values.
#include "cfuse/kernel/check.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>

#include "cfuse/kernel/measurement_set.h"
#include "cfuse/kernel/values.h"

namespace cfuse {
namespace {

TEST_CASE("checks: a failed comparison names the condition and both values", "[kernel]") {
  const int rows = 3;
  const long n = 4;
  CHECK_THROWS_WITH([&] { CFUSE_CHECK_EQ(rows, n); }(),
                    Catch::Contains("check 'rows == n' failed: 3 vs 4"));
  CHECK_THROWS_AS([&] { CFUSE_CHECK_EQ(rows, n); }(), InternalError);
  CHECK_THROWS_WITH([] { CFUSE_CHECK_GT(0.5, 2.0); }(),
                    Catch::Contains("'0.5 > 2.0' failed: 0.5 vs 2"));
  CHECK_THROWS_WITH([&] { CFUSE_CHECK_LE(n, rows); }(), Catch::Contains("4 vs 3"));
  CHECK_THROWS([&] { CFUSE_CHECK_NE(rows, 3); }());
  CHECK_THROWS([&] { CFUSE_CHECK_LT(rows, 3); }());
  CHECK_THROWS([&] { CFUSE_CHECK_GE(rows, 4); }());
  // Holding, they do nothing; each operand is evaluated once.
  int calls = 0;
  CHECK_NOTHROW([&] { CFUSE_CHECK_EQ(++calls, 1); }());
  CHECK(calls == 1);
  CHECK_NOTHROW([&] { CFUSE_CHECK_LE(rows, n); }());
  CHECK_NOTHROW([&] { CFUSE_CHECK_GE(n, rows); }());
  CHECK_NOTHROW([&] { CFUSE_CHECK_NE(rows, n); }());
  // A type fmt cannot print gives the condition alone.
  struct Opaque {
    bool operator==(const Opaque&) const { return false; }
  };
  CHECK_THROWS_WITH([] { CFUSE_CHECK_EQ(Opaque{}, Opaque{}); }(),
                    Catch::EndsWith("check 'Opaque{} == Opaque{}' failed"));
}

TEST_CASE("checks: values that do not fit their blocks break the contract", "[kernel]") {
  const std::vector<Block> blocks = {{BlockKind::kPose, 0, 0, "a"},
                                     {BlockKind::kPoint, 0, 6, "p"},
                                     {BlockKind::kSlack, 0, 9, "k.slack"}};
  Values values;
  values.poses.resize(1);
  values.points.resize(1);
  values.slacks.resize(1);
  CHECK_NOTHROW(CheckValuesFit(blocks, values));
  values.points.clear();
  CHECK_THROWS_AS(CheckValuesFit(blocks, values), InternalError);
  values.points.resize(1);
  values.slacks.clear();
  CHECK_THROWS_WITH(CheckValuesFit(blocks, values), Catch::Contains("0 vs 0"));
}

TEST_CASE("checks: a measurement set built in code keeps the contract or is refused", "[kernel]") {
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

}  // namespace
}  // namespace cfuse
