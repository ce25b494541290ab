// The joint types' models (joint_model.h): each says what its type does.
#include <cmath>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/fixed_joint.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/constraints/kinds/planar_joint.h"
#include "cfuse/constraints/kinds/prismatic_joint.h"
#include "cfuse/constraints/kinds/revolute_joint.h"
#include "cfuse/constraints/kinds/spherical_joint.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/so3.h"

namespace cfuse {
namespace {

// Column `column` of T: a rotation ω about the line through o, ω × (p - o) = ω × p + o × ω.
void RotationAbout(int column, const Eigen::Vector3d& omega, const Eigen::Vector3d& o,
                   Eigen::MatrixXd* T) {
  T->col(column).head<3>() = omega;
  T->col(column).tail<3>() = o.cross(omega);
}

void Translation(int column, const Eigen::Vector3d& v, Eigen::MatrixXd* T) {
  T->col(column).tail<3>() = v;
}

// The rotation vector from `from`'s orientation to `to`'s, in `from`'s frame.
Eigen::Vector3d RelativeRotation(const Rigid3d& from, const Rigid3d& to) {
  const Eigen::AngleAxisd aa((from.rotation.conjugate() * to.rotation).toRotationMatrix());
  return aa.angle() * aa.axis();
}

void Turn(const Eigen::Quaterniond& by, Rigid3d* motion) {
  motion->rotation = (motion->rotation * by).normalized();
}

// A joint whose state is its scalar variable q: its one parameter steps q itself.
class VariableJointModel : public JointModel {
 public:
  bool HasVariable() const override { return true; }
  void Retract(const Eigen::Vector3d& /*axis*/, const double* d, double* q,
               Rigid3d* /*motion*/) const override {
    *q += d[0];
  }
  void Difference(const Eigen::Vector3d& /*axis*/, double q_from, double q_to,
                  const Rigid3d& /*from*/, const Rigid3d& /*to*/, double* d) const override {
    d[0] = q_to - q_from;
  }
};

// Rotation about the axis by the variable: revolute (limited) and continuous.
class RevoluteModel : public VariableJointModel {
 public:
  const std::vector<Parameter>& Parameters() const override {
    static const std::vector<Parameter> kParameters = {{"", true}};
    return kParameters;
  }
  Rigid3d Motion(const Eigen::Vector3d& axis, double q) const override {
    return Rigid3d(Eigen::Matrix3d(RotationAboutAxis<double>(axis, q)), Eigen::Vector3d::Zero());
  }
  double Variable(const Eigen::Vector3d& axis, const Rigid3d& motion) const override {
    const Eigen::AngleAxisd turned(motion.rotation);
    return turned.angle() * (turned.axis().dot(axis) < 0 ? -1 : 1);
  }
  void Twists(const Eigen::Vector3d& axis, const Rigid3d& A, const Rigid3d& /*B*/,
              Eigen::MatrixXd* T, int first) const override {
    RotationAbout(first, A.RotationMatrix() * axis, A.translation, T);
  }
  bool NearConfiguration(const Eigen::Vector3d& axis,
                         const Eigen::Quaterniond& relative) const override {
    return (relative * axis).dot(axis) > 0.5;
  }
  std::shared_ptr<const ResidualFunction> MakeResidual(const JointGeometry& geometry,
                                                       const std::string& name) const override {
    return std::make_shared<JointResidual<RevoluteJoint>>(geometry, name);
  }
};

// Translation along the axis by the variable.
class PrismaticModel : public VariableJointModel {
 public:
  const std::vector<Parameter>& Parameters() const override {
    static const std::vector<Parameter> kParameters = {{"", false}};
    return kParameters;
  }
  Rigid3d Motion(const Eigen::Vector3d& axis, double q) const override {
    return Rigid3d(Eigen::Quaterniond::Identity(), axis * q);
  }
  double Variable(const Eigen::Vector3d& axis, const Rigid3d& motion) const override {
    return motion.translation.dot(axis);
  }
  void Twists(const Eigen::Vector3d& axis, const Rigid3d& A, const Rigid3d& /*B*/,
              Eigen::MatrixXd* T, int first) const override {
    Translation(first, A.RotationMatrix() * axis, T);
  }
  bool NearConfiguration(const Eigen::Vector3d& /*axis*/,
                         const Eigen::Quaterniond& relative) const override {
    return relative.angularDistance(Eigen::Quaterniond::Identity()) < 0.5;
  }
  std::shared_ptr<const ResidualFunction> MakeResidual(const JointGeometry& geometry,
                                                       const std::string& name) const override {
    return std::make_shared<JointResidual<PrismaticJoint>>(geometry, name);
  }
};

// Any rotation about the joint's centre: three angles about the child frame's axes.
class SphericalModel : public JointModel {
 public:
  const std::vector<Parameter>& Parameters() const override {
    static const std::vector<Parameter> kParameters = {{"rx", true}, {"ry", true}, {"rz", true}};
    return kParameters;
  }
  Rigid3d Nearest(const Eigen::Vector3d& /*axis*/, const Rigid3d& relative) const override {
    return Rigid3d(relative.rotation, Eigen::Vector3d::Zero());
  }
  void Twists(const Eigen::Vector3d& /*axis*/, const Rigid3d& /*A*/, const Rigid3d& B,
              Eigen::MatrixXd* T, int first) const override {
    const Eigen::Matrix3d RB = B.RotationMatrix();
    for (int i = 0; i < 3; ++i) RotationAbout(first + i, RB.col(i), B.translation, T);
  }
  void Retract(const Eigen::Vector3d& /*axis*/, const double* d, double* /*q*/,
               Rigid3d* motion) const override {
    Turn(Eigen::Quaterniond(ExpSO3<double>(Eigen::Vector3d(d[0], d[1], d[2]))), motion);
  }
  void Difference(const Eigen::Vector3d& /*axis*/, double /*q_from*/, double /*q_to*/,
                  const Rigid3d& from, const Rigid3d& to, double* d) const override {
    Eigen::Map<Eigen::Vector3d>{d} = RelativeRotation(from, to);
  }
  bool NearConfiguration(const Eigen::Vector3d& /*axis*/,
                         const Eigen::Quaterniond& /*relative*/) const override {
    return true;
  }
  std::shared_ptr<const ResidualFunction> MakeResidual(const JointGeometry& geometry,
                                                       const std::string& name) const override {
    return std::make_shared<JointResidual<SphericalJoint>>(geometry, name);
  }
};

// No motion at all.
class FixedModel : public JointModel {
 public:
  const std::vector<Parameter>& Parameters() const override {
    static const std::vector<Parameter> kParameters;
    return kParameters;
  }
  void Twists(const Eigen::Vector3d& /*axis*/, const Rigid3d& /*A*/, const Rigid3d& /*B*/,
              Eigen::MatrixXd* /*T*/, int /*first*/) const override {}
  void Retract(const Eigen::Vector3d& /*axis*/, const double* /*d*/, double* /*q*/,
               Rigid3d* /*motion*/) const override {}
  void Difference(const Eigen::Vector3d& /*axis*/, double /*q_from*/, double /*q_to*/,
                  const Rigid3d& /*from*/, const Rigid3d& /*to*/, double* /*d*/) const override {}
  bool NearConfiguration(const Eigen::Vector3d& /*axis*/,
                         const Eigen::Quaterniond& relative) const override {
    return relative.angularDistance(Eigen::Quaterniond::Identity()) < 0.5;
  }
  std::shared_ptr<const ResidualFunction> MakeResidual(const JointGeometry& geometry,
                                                       const std::string& name) const override {
    return std::make_shared<JointResidual<FixedJoint>>(geometry, name);
  }
};

// A rotation about the axis and a translation in the plane normal to it (e1, e2 spanning it).
class PlanarModel : public JointModel {
 public:
  const std::vector<Parameter>& Parameters() const override {
    static const std::vector<Parameter> kParameters = {{"angle", true}, {"u", false}, {"v", false}};
    return kParameters;
  }
  // The rotation's angle about the axis, the translation's part normal to it.
  Rigid3d Nearest(const Eigen::Vector3d& axis, const Rigid3d& relative) const override {
    Eigen::Vector3d e1, e2;
    OrthonormalComplement<double>(axis, &e1, &e2);
    const Eigen::Vector3d r1 = relative.rotation * e1;
    const double angle = std::atan2(e2.dot(r1), e1.dot(r1));
    return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis)),
                   relative.translation - axis * axis.dot(relative.translation));
  }
  void Twists(const Eigen::Vector3d& axis, const Rigid3d& A, const Rigid3d& B, Eigen::MatrixXd* T,
              int first) const override {
    Eigen::Vector3d e1, e2;
    OrthonormalComplement<double>(axis, &e1, &e2);
    const Eigen::Matrix3d RA = A.RotationMatrix();
    RotationAbout(first, RA * axis, B.translation, T);
    Translation(first + 1, RA * e1, T);
    Translation(first + 2, RA * e2, T);
  }
  void Retract(const Eigen::Vector3d& axis, const double* d, double* /*q*/,
               Rigid3d* motion) const override {
    Eigen::Vector3d e1, e2;
    OrthonormalComplement<double>(axis, &e1, &e2);
    Turn(Eigen::Quaterniond(Eigen::AngleAxisd(d[0], axis)), motion);
    motion->translation += d[1] * e1 + d[2] * e2;
  }
  void Difference(const Eigen::Vector3d& axis, double /*q_from*/, double /*q_to*/,
                  const Rigid3d& from, const Rigid3d& to, double* d) const override {
    Eigen::Vector3d e1, e2;
    OrthonormalComplement<double>(axis, &e1, &e2);
    d[0] = axis.dot(RelativeRotation(from, to));
    d[1] = e1.dot(to.translation - from.translation);
    d[2] = e2.dot(to.translation - from.translation);
  }
  bool NearConfiguration(const Eigen::Vector3d& axis,
                         const Eigen::Quaterniond& relative) const override {
    return (relative * axis).dot(axis) > 0.5;
  }
  std::shared_ptr<const ResidualFunction> MakeResidual(const JointGeometry& geometry,
                                                       const std::string& name) const override {
    return std::make_shared<JointResidual<PlanarJoint>>(geometry, name);
  }
};

// Any motion: three angles about the child frame's axes, three translations along the
// parent frame's.
class FloatingModel : public JointModel {
 public:
  const std::vector<Parameter>& Parameters() const override {
    static const std::vector<Parameter> kParameters = {{"rx", true},  {"ry", true},  {"rz", true},
                                                       {"tx", false}, {"ty", false}, {"tz", false}};
    return kParameters;
  }
  Rigid3d Nearest(const Eigen::Vector3d& /*axis*/, const Rigid3d& relative) const override {
    return relative;
  }
  void Twists(const Eigen::Vector3d& /*axis*/, const Rigid3d& A, const Rigid3d& B,
              Eigen::MatrixXd* T, int first) const override {
    const Eigen::Matrix3d RA = A.RotationMatrix(), RB = B.RotationMatrix();
    for (int i = 0; i < 3; ++i) {
      RotationAbout(first + i, RB.col(i), B.translation, T);
      Translation(first + 3 + i, RA.col(i), T);
    }
  }
  void Retract(const Eigen::Vector3d& /*axis*/, const double* d, double* /*q*/,
               Rigid3d* motion) const override {
    Turn(Eigen::Quaterniond(ExpSO3<double>(Eigen::Vector3d(d[0], d[1], d[2]))), motion);
    motion->translation += Eigen::Vector3d(d[3], d[4], d[5]);
  }
  void Difference(const Eigen::Vector3d& /*axis*/, double /*q_from*/, double /*q_to*/,
                  const Rigid3d& from, const Rigid3d& to, double* d) const override {
    Eigen::Map<Eigen::Vector3d>{d} = RelativeRotation(from, to);
    Eigen::Map<Eigen::Vector3d>{d + 3} = to.translation - from.translation;
  }
  bool NearConfiguration(const Eigen::Vector3d& /*axis*/,
                         const Eigen::Quaterniond& /*relative*/) const override {
    return true;
  }
  std::shared_ptr<const ResidualFunction> MakeResidual(const JointGeometry& /*geometry*/,
                                                       const std::string& /*name*/) const override {
    return nullptr;
  }
};

}  // namespace

const JointModel& ModelOf(JointType type) {
  static const RevoluteModel kRevolute;
  static const PrismaticModel kPrismatic;
  static const SphericalModel kSpherical;
  static const FixedModel kFixed;
  static const PlanarModel kPlanar;
  static const FloatingModel kFloating;
  switch (type) {
    case JointType::kRevolute:
    case JointType::kContinuous:
      return kRevolute;
    case JointType::kPrismatic:
      return kPrismatic;
    case JointType::kSpherical:
      return kSpherical;
    case JointType::kFixed:
      return kFixed;
    case JointType::kPlanar:
      return kPlanar;
    case JointType::kFloating:
      return kFloating;
  }
  CFUSE_CHECK_MSG(false, "unknown joint type");
  return kFixed;
}

}  // namespace cfuse
