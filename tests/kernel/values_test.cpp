// Blocks and their values: the contract that values fit their blocks, ⊞ in the chart of
// values.h (rotation on the right, translation in the world) worked by hand, and ⊟ inverting ⊞
// with the rotation's angle in [0, π].
#include "cfuse/kernel/values.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

TEST_CASE("values: values that do not fit their blocks break the contract", "[kernel]") {
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

// A pose, a point and a slack, laid out with a gap (tangent coordinates 9 and 10 belong to none).
struct State {
  std::vector<Block> blocks = {{BlockKind::kPoint, 0, 6, "p"},
                               {BlockKind::kPose, 0, 0, "a"},
                               {BlockKind::kSlack, 0, 11, "k.slack"}};
  Values values;
  State() {
    values.poses = {Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())),
                            Eigen::Vector3d(1, -2, 0.5))};
    values.points = {Eigen::Vector3d(0.1, 0.2, 0.3)};
    values.slacks = {0.7};
  }
};

TEST_CASE("values: the pose turns on the right and moves in the world", "[kernel]") {
  State s;
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(12);
  delta.segment<6>(0) << 0, 0, M_PI / 2, 1, 2, 3;
  delta.segment<3>(6) << -0.1, 0.5, 1;
  delta[11] = -0.2;
  Values moved = s.values;
  Retract(s.blocks, delta, &moved);
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix() *
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  CHECK((moved.poses[0].RotationMatrix() - expected).norm() < 1e-14);
  CHECK(moved.poses[0].rotation.norm() == Approx(1).epsilon(1e-14));
  CHECK(moved.poses[0].translation == Eigen::Vector3d(2, 0, 3.5));
  CHECK(moved.points[0].isApprox(Eigen::Vector3d(0, 0.7, 1.3)));
  CHECK(moved.slacks[0] == Approx(0.5));

  // One block alone: the same.
  Values one = s.values;
  RetractBlock(s.blocks[1], delta.data(), &one);
  CHECK(one.poses[0].rotation.isApprox(moved.poses[0].rotation));
  CHECK(one.points[0] == s.values.points[0]);

  // Too short a delta breaks the contract.
  CHECK_THROWS_AS(Retract(s.blocks, Eigen::VectorXd::Zero(11), &moved), InternalError);
}

TEST_CASE("values: local coordinates invert the retraction", "[kernel]") {
  const State s;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd delta(12);
    for (int i = 0; i < 12; ++i) delta[i] = u(rng);
    delta.segment<3>(0) *= 1.7;     // rotations up to about 3 rad, inside the chart
    delta.segment<2>(9).setZero();  // the gap
    Values to = s.values;
    Retract(s.blocks, delta, &to);
    const Eigen::VectorXd back = LocalCoordinates(s.blocks, s.values, to);
    REQUIRE(back.size() == 12);
    INFO("trial " << trial);
    CHECK((back - delta).norm() < 1e-12);
    double block_delta[6];
    LocalCoordinatesOfBlock(s.blocks[1], s.values, to, block_delta);
    CHECK((Eigen::Map<Eigen::Matrix<double, 6, 1>>(block_delta) - delta.head<6>()).norm() < 1e-12);
  }
  // Past half a turn the logarithm takes the shorter way round: 1.5π about z is -π/2.
  Eigen::VectorXd turn = Eigen::VectorXd::Zero(12);
  turn[2] = 1.5 * M_PI;
  Values to = s.values;
  Retract(s.blocks, turn, &to);
  const Eigen::VectorXd back = LocalCoordinates(s.blocks, s.values, to);
  CHECK((back.head<3>() - Eigen::Vector3d(0, 0, -M_PI / 2)).norm() < 1e-12);
  CHECK(back.tail<9>().norm() == 0);
}

}  // namespace
}  // namespace cfuse
