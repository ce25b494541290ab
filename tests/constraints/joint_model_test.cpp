// What a joint model says of its variable (cfuse/constraints/joint_model.h): a length for a
// prismatic joint, an angle for the others with a variable, and Variable() inverting Motion().
#include "cfuse/constraints/joint_model.h"

#include <catch2/catch.hpp>
#include <cmath>

namespace cfuse {
namespace {

TEST_CASE("joint models: the variable's kind, and Variable() inverts Motion()", "[constraints]") {
  CHECK(ModelOf(JointType::kPrismatic).VariableIsLength());
  for (JointType t : {JointType::kRevolute, JointType::kContinuous, JointType::kSpherical,
                      JointType::kFixed, JointType::kPlanar, JointType::kFloating}) {
    CHECK_FALSE(ModelOf(t).VariableIsLength());
  }
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  for (double q : {-3.0, -1.2, 0.0, 0.4, 2.9}) {
    for (JointType t : {JointType::kRevolute, JointType::kContinuous, JointType::kPrismatic}) {
      const JointModel& model = ModelOf(t);
      REQUIRE(model.HasVariable());
      CHECK(model.Variable(axis, model.Motion(axis, q)) == Approx(q).margin(1e-12));
      // The same motion seen with the axis reversed: the opposite variable.
      CHECK(model.Variable(-axis, model.Motion(axis, q)) == Approx(-q).margin(1e-12));
    }
  }
}

}  // namespace
}  // namespace cfuse
