// What each joint type's model says (constraints/src/joint_models.cpp): its parameters, Variable()
// inverting Motion(), the twists of its parameters against the motion their retraction gives a
// point on the child (central differences), ⊟ inverting ⊞, the nearest motion it allows, when
// frames are near one of its configurations, and a residual that is zero exactly on its motions.
#include <catch2/catch.hpp>
#include <cmath>
#include <string>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

const JointType kAll[] = {JointType::kRevolute,  JointType::kContinuous, JointType::kPrismatic,
                          JointType::kSpherical, JointType::kFixed,      JointType::kPlanar,
                          JointType::kFloating};

Eigen::Quaterniond Turn(double angle, const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()));
}

// A motion of the joint's kind, away from the identity.
Rigid3d SomeMotion(JointType t, const Eigen::Vector3d& axis) {
  Eigen::Vector3d e1, e2;
  OrthonormalComplement<double>(axis, &e1, &e2);
  switch (t) {
    case JointType::kSpherical:
      return Rigid3d(Turn(0.6, {1, 1, 0}), Eigen::Vector3d::Zero());
    case JointType::kPlanar:
      return Rigid3d(Turn(0.8, axis), 0.3 * e1 - 0.2 * e2);
    case JointType::kFloating:
      return Rigid3d(Turn(1.1, {0, 1, 2}), Eigen::Vector3d(0.1, -0.4, 0.2));
    case JointType::kFixed:
      return Rigid3d();
    default:
      return ModelOf(t).Motion(axis, 0.4);
  }
}

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

TEST_CASE("joint models: parameters by type", "[constraints]") {
  auto names = [](JointType t) {
    std::string s;
    for (const JointModel::Parameter& p : ModelOf(t).Parameters()) {
      s += std::string(p.suffix) + (p.angle ? "(a) " : "(l) ");
    }
    return s;
  };
  CHECK(names(JointType::kRevolute) == "(a) ");
  CHECK(names(JointType::kContinuous) == "(a) ");
  CHECK(names(JointType::kPrismatic) == "(l) ");
  CHECK(names(JointType::kSpherical) == "rx(a) ry(a) rz(a) ");
  CHECK(names(JointType::kFixed).empty());
  CHECK(names(JointType::kPlanar) == "angle(a) u(l) v(l) ");
  CHECK(names(JointType::kFloating) == "rx(a) ry(a) rz(a) tx(l) ty(l) tz(l) ");
  CHECK_THROWS_AS(ModelOf(static_cast<JointType>(42)), InternalError);
}

TEST_CASE("joint models: each parameter's twist is how its step moves the child", "[constraints]") {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  const Rigid3d A(Turn(0.7, {0.2, 1, -0.4}), Eigen::Vector3d(0.5, -0.3, 1.2));
  const Eigen::Vector3d point(0.3, -0.2, 0.7);  // on the child, in its joint frame
  for (JointType t : kAll) {
    const JointModel& model = ModelOf(t);
    const int n = model.ParameterCount();
    const double q0 = 0.4;
    const Rigid3d motion0 = SomeMotion(t, axis);
    const Rigid3d B = A * motion0;
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(6, n + 1);
    model.Twists(axis, A, B, &T, 1);  // written from column 1 on
    CHECK(T.col(0).isZero());
    // The child's point after a step d of the parameters.
    auto moved = [&](const double* d) {
      double q = q0;
      Rigid3d motion = motion0;
      model.Retract(axis, d, &q, &motion);
      return (A * (model.HasVariable() ? model.Motion(axis, q) : motion)) * point;
    };
    const Eigen::Vector3d p = B * point;
    for (int i = 0; i < n; ++i) {
      double plus[6] = {}, minus[6] = {};
      plus[i] = 1e-6;
      minus[i] = -1e-6;
      const Eigen::Vector3d numeric = (moved(plus) - moved(minus)) / 2e-6;
      const Eigen::Vector3d twist = T.col(1 + i).head<3>().cross(p) + T.col(1 + i).tail<3>();
      INFO(JointTypeName(t) << " parameter " << i);
      CHECK((numeric - twist).norm() < 1e-8);
    }
    // ⊟ inverts ⊞.
    const double d[6] = {0.05, -0.02, 0.03, 0.01, 0.04, -0.06};
    double q = q0;
    Rigid3d motion = motion0;
    model.Retract(axis, d, &q, &motion);
    double back[6] = {};
    model.Difference(axis, q0, q, motion0, motion, back);
    for (int i = 0; i < n; ++i) CHECK(back[i] == Approx(d[i]).margin(1e-12));
  }
}

TEST_CASE("joint models: the nearest motion, and frames near a configuration", "[constraints]") {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  const Rigid3d relative(Turn(0.9, {1, 0.3, -0.2}), Eigen::Vector3d(0.2, 0.5, -0.1));
  const Rigid3d spherical = ModelOf(JointType::kSpherical).Nearest(axis, relative);
  CHECK(spherical.rotation.isApprox(relative.rotation));
  CHECK(spherical.translation.isZero());
  CHECK(ModelOf(JointType::kFloating).Nearest(axis, relative).translation == relative.translation);
  // Planar: a turn about the axis and a shift across it; one of its own motions is its nearest.
  const JointModel& planar = ModelOf(JointType::kPlanar);
  const Rigid3d nearest = planar.Nearest(axis, relative);
  CHECK((nearest.rotation * axis - axis).norm() < 1e-12);
  CHECK(std::abs(nearest.translation.dot(axis)) < 1e-12);
  CHECK((nearest.translation - (relative.translation - axis * axis.dot(relative.translation)))
            .norm() < 1e-12);
  const Rigid3d own = SomeMotion(JointType::kPlanar, axis);
  CHECK(planar.Nearest(axis, own).rotation.angularDistance(own.rotation) < 1e-12);
  CHECK((planar.Nearest(axis, own).translation - own.translation).norm() < 1e-12);
  CHECK(ModelOf(JointType::kRevolute).Nearest(axis, relative).translation.isZero());

  // Near: about the axis for a revolute or planar joint; little turned for the others with a
  // limit on turning; always for a spherical or floating joint.
  Eigen::Vector3d e1, e2;
  OrthonormalComplement<double>(axis, &e1, &e2);
  const Eigen::Quaterniond about = Turn(2.5, axis), across = Turn(1.5, e1), slight = Turn(0.4, e1);
  for (JointType t : {JointType::kRevolute, JointType::kPlanar}) {
    CHECK(ModelOf(t).NearConfiguration(axis, about));
    CHECK_FALSE(ModelOf(t).NearConfiguration(axis, across));
  }
  for (JointType t : {JointType::kPrismatic, JointType::kFixed}) {
    CHECK(ModelOf(t).NearConfiguration(axis, slight));
    CHECK_FALSE(ModelOf(t).NearConfiguration(axis, about));
  }
  for (JointType t : {JointType::kSpherical, JointType::kFloating}) {
    CHECK(ModelOf(t).NearConfiguration(axis, across));
  }
}

TEST_CASE("joint models: each residual vanishes on its motions only", "[constraints]") {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  Eigen::Vector3d e1, e2;
  OrthonormalComplement<double>(axis, &e1, &e2);
  const JointGeometry geometry(Rigid3d(Turn(0.3, {1, 0, 0}), {0.1, 0.2, 0.3}),
                               Rigid3d(Turn(-0.5, {0, 1, 1}), {-0.2, 0, 0.1}), axis);
  const Rigid3d parent(Turn(0.8, {1, 2, 3}), {1, -1, 0.5});
  auto residual_norm = [&](JointType t, const Rigid3d& motion) {
    const auto f = ModelOf(t).MakeResidual(geometry, JointTypeName(t));
    REQUIRE(f != nullptr);
    const Rigid3d child =
        parent * geometry.parent_from_joint * motion * geometry.child_from_joint.Inverse();
    const BlockState<double> x[] = {{parent.RotationMatrix(), parent.translation},
                                    {child.RotationMatrix(), child.translation}};
    Eigen::VectorXd r(f->dimension());
    f->Evaluate(std::span<const BlockState<double>>(x), r.data());
    return r.norm();
  };
  const struct {
    JointType type;
    Rigid3d not_allowed;
  } cases[] = {
      {JointType::kRevolute, Rigid3d(Eigen::Quaterniond::Identity(), 0.1 * e1)},
      {JointType::kContinuous, Rigid3d(Turn(0.2, e2), Eigen::Vector3d::Zero())},
      {JointType::kPrismatic, Rigid3d(Turn(0.2, axis), Eigen::Vector3d::Zero())},
      {JointType::kSpherical, Rigid3d(Eigen::Quaterniond::Identity(), 0.1 * axis)},
      {JointType::kFixed, Rigid3d(Turn(0.1, axis), Eigen::Vector3d::Zero())},
      {JointType::kPlanar, Rigid3d(Turn(0.8, axis), 0.1 * axis)},
  };
  for (const auto& c : cases) {
    INFO(JointTypeName(c.type));
    CHECK(residual_norm(c.type, SomeMotion(c.type, axis)) < 1e-12);
    CHECK(residual_norm(c.type, c.not_allowed) > 1e-3);
  }
  CHECK(ModelOf(JointType::kFloating).MakeResidual(geometry, "floating") == nullptr);
}

}  // namespace
}  // namespace cfuse
