// Joint variables read off component poses: the values forward kinematics was given, mimic
// joints left out on request, the Jacobian against central differences, and the covariance as
// J P Jᵀ.
#include "cfuse/interp/joint_estimates.h"

#include <catch2/catch.hpp>
#include <random>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/urdf.h"
#include "cfuse/kernel/evaluate.h"
#include "test_util.h"

namespace cfuse {
namespace {

int TangentSize(const ConstraintGraph& g) {
  return g.blocks.back().tangent_offset + TangentDim(g.blocks.back().kind);
}

TEST_CASE("joint estimates: the values forward kinematics was given are read back", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/planar-arm.yaml"));
  const std::vector<JointValue> given = {
      {"shoulder", 0.4, {}}, {"elbow", -1.1, {}}, {"wrist", 2.0, {}}};
  const Values x = ForwardKinematics(g, CompleteJointValues(g, given));
  const Eigen::VectorXd q = JointValues(g, x);
  REQUIRE(q.size() == 3);
  for (const JointValue& v : given) CHECK(q[g.FindJoint(v.name)] == Approx(v.value).margin(1e-12));
  // The nominal geometry is at the model's own positions (30, 45 and -30 degrees).
  const Eigen::VectorXd nominal = JointValues(g, g.nominal);
  CHECK(nominal[0] == Approx(30 * M_PI / 180));
  CHECK(nominal[1] == Approx(45 * M_PI / 180));
  CHECK(nominal[2] == Approx(-30 * M_PI / 180));
}

TEST_CASE("joint estimates: a mimic joint follows its leader and is left out on request",
          "[interp]") {
  // arm.urdf: grip_b mimics grip_a (multiplier 1); the fixed and locked joints have no variable.
  const ConstraintGraph g = ImportUrdf(testing::SourcePath("tests/data/urdf/arm.urdf"));
  const Values x =
      ForwardKinematics(g, CompleteJointValues(g, {{"shoulder", 0.3, {}}, {"grip_a", 0.012, {}}}));
  const JointEstimates all = EstimateJoints(g, MakePrior(g.blocks, x, {}));
  const JointEstimates independent = EstimateJoints(g, MakePrior(g.blocks, x, {}), true);
  const int a = g.FindJoint("grip_a"), b = g.FindJoint("grip_b");
  REQUIRE(a >= 0);
  REQUIRE(b >= 0);
  auto position = [](const std::vector<int>& joints, int j) {
    return static_cast<int>(std::find(joints.begin(), joints.end(), j) - joints.begin());
  };
  REQUIRE(position(all.joints, b) < static_cast<int>(all.joints.size()));
  CHECK(all.values[position(all.joints, a)] == Approx(0.012).margin(1e-12));
  CHECK(all.values[position(all.joints, b)] == Approx(0.012).margin(1e-12));
  CHECK(independent.joints.size() == all.joints.size() - 1);
  CHECK(position(independent.joints, b) == static_cast<int>(independent.joints.size()));
  CHECK(JointValues(g, x, true).size() == independent.values.size());
  CHECK(JointJacobian(g, x, true).rows() == independent.values.size());
  // Every joint listed has a variable: the fixed mount is not among them.
  CHECK(position(all.joints, g.FindJoint("plate_mount")) == static_cast<int>(all.joints.size()));
}

TEST_CASE("solve: the joints' Jacobian matches finite differences", "[interp]") {
  for (const char* file : {"examples/hinged-box.yaml", "examples/planar-arm.yaml"}) {
    CAPTURE(file);
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    Values x = g.nominal;
    std::mt19937 rng(5);
    std::normal_distribution<double> n(0, 0.3);
    Eigen::VectorXd move(g.blocks.back().tangent_offset + TangentDim(g.blocks.back().kind));
    for (int i = 0; i < move.size(); ++i) move[i] = n(rng);
    Retract(g.blocks, move, &x);  // away from the nominal geometry's special values
    const Eigen::MatrixXd analytic = JointJacobian(g, x);
    REQUIRE(analytic.rows() == JointValues(g, x).size());
    REQUIRE(analytic.cols() == move.size());
    const double h = 1e-6;
    for (int i = 0; i < move.size(); ++i) {
      Eigen::VectorXd step = Eigen::VectorXd::Zero(move.size());
      step[i] = h;
      Values plus = x, minus = x;
      Retract(g.blocks, step, &plus);
      Retract(g.blocks, -step, &minus);
      const Eigen::VectorXd numeric = (JointValues(g, plus) - JointValues(g, minus)) / (2 * h);
      CHECK((numeric - analytic.col(i)).norm() <= 1e-6 * (1 + numeric.norm()));
    }
  }
}

TEST_CASE("joint estimates: the covariance is J P Jᵀ of the poses' covariance", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/planar-arm.yaml"));
  GaussianState state = MakePrior(g.blocks, g.nominal, {});
  // A dense covariance, correlated across the components.
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 0.1);
  const int size = TangentSize(g);
  Eigen::MatrixXd root(size, size);
  for (int i = 0; i < size; ++i)
    for (int j = 0; j < size; ++j) root(i, j) = n(rng);
  state.covariance = root * root.transpose() + 1e-3 * Eigen::MatrixXd::Identity(size, size);
  const JointEstimates e = EstimateJoints(g, state);
  const Eigen::MatrixXd J = JointJacobian(g, state.mean);
  const Eigen::MatrixXd expected = J * state.covariance * J.transpose();
  REQUIRE(e.covariance.rows() == expected.rows());
  CHECK((e.covariance - expected).norm() <= 1e-12 * expected.norm());
  CHECK((e.values - JointValues(g, state.mean)).norm() == 0);
  CHECK(e.joints == std::vector<int>{0, 1, 2});
}

}  // namespace
}  // namespace cfuse
