// Pose files (the results format's components and points): what solve, simulate and fk write
// reads back; every malformed entry is refused with the file, line, column and entry.
#include "cfuse/dsl/pose_reader.h"

#include <catch2/catch.hpp>

#include "test_util.h"

namespace cfuse {
namespace {

TEST_CASE("poses: a results file and a truth file read back", "[dsl]") {
  const PoseSet result = ReadPosesFromString(R"({
 "components": {"box": {"position": [0.1, -0.2, 1.5], "quaternion": [0.5, 0.5, -0.5, 0.5],
                        "covariance": [[1]]},
                "lid": {"position": [0, 0, 1], "quaternion": [0.99999, 0, 0, 0]}},
 "points": {"p3": {"xyz": [1, 2, 3], "cov": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}},
 "joints": {"hinge": {"value": 0.5, "sigma": 0.01}},
 "matches": ["box.c000", null],
 "time_ms": 0.2})",
                                             "r.json");
  REQUIRE(result.components.size() == 2);
  CHECK(result.components[0].name == "box");
  CHECK(result.components[0].pose.translation.isApprox(Eigen::Vector3d(0.1, -0.2, 1.5)));
  CHECK(result.components[0].pose.rotation.w() == 0.5);
  CHECK(result.components[0].pose.rotation.y() == -0.5);
  CHECK(result.components[1].pose.rotation.norm() == Approx(1).epsilon(1e-15));  // normalised
  CHECK(result.components[1].where.element == "components.lid");
  REQUIRE(result.points.size() == 1);
  CHECK(result.points[0].xyz.z() == 3);
  const PoseSet truth = ReadPosesFromString("points: {p1: [1, 2, 3], p2: [4, 5, 6]}", "t.yaml");
  REQUIRE(truth.points.size() == 2);
  CHECK(truth.points[1].name == "p2");
  CHECK(truth.points[1].xyz.x() == 4);
  CHECK(truth.points[1].where.line == 1);
}

TEST_CASE("poses: every malformed file is refused where and how it should be", "[dsl]") {
  const testing::BadCase cases[] = {
      {"{}", 1, 1, "a pose file needs 'components' (or 'points')"},
      {"- 1", 1, 1, "a pose file is a mapping"},
      {"components: [1]", 1, 13, "components must be a mapping"},
      {"components: {box: {quaternion: [1, 0, 0, 0]}}", 1, 19, "components.box needs 'position'"},
      {"components: {box: {position: [0, 0, 0]}}", 1, 19, "components.box needs 'quaternion'"},
      {"components: {box: {position: [0, 0], quaternion: [1, 0, 0, 0]}}", 1, 30,
       "components.box position must be a list of 3 numbers, got 2"},
      {"components: {box: {position: [0, 0, .nan], quaternion: [1, 0, 0, 0]}}", 1, 37,
       "components.box position must be finite"},
      {"components: {box: {position: [0, 0, 0], quaternion: [1, 0, 0]}}", 1, 53,
       "components.box quaternion must be a list of 4 numbers, got 3"},
      {"components: {box: {position: [0, 0, 0], quaternion: [2, 0, 0, 0]}}", 1, 53,
       "components.box quaternion [w, x, y, z] must have norm 1, got 2"},
      {"components: {box: {position: [0, 0, 0], quaternion: [0, 0, 0, 0]}}", 1, 53,
       "components.box quaternion [w, x, y, z] must have norm 1, got 0"},
      {"components: {box: 3}", 1, 19, "components.box must be a mapping"},
      {"components: {box: {position: [0, 0, 0], quaternion: [1, 0, 0, 0]}, box: {}}", 1, 68,
       "duplicate key 'box' in components"},
      {"points: {p1: [1, 2]}", 1, 14, "points.p1 must be a list of 3 numbers, got 2"},
      {"points: {p1: {xyz: [1, 2, x]}}", 1, 27, "points.p1 xyz must be a number, got 'x'"},
      {"points: {p1: {cov: [[1]]}}", 1, 14, "points.p1 needs 'xyz'"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* file) { return ReadPosesFromString(text, file); });
  CHECK_THROWS_WITH(ReadPoses("no/such/poses.json"),
                    "no/such/poses.json: error: cannot open: no such file");
}

}  // namespace
}  // namespace cfuse
