// Adapts a joint kind (spherical_joint.h, revolute_joint.h, ...) to a ResidualFunction over
// the slots (parent pose, child pose); also the joint variable and the joint limit, which
// work on the same two slots.
#pragma once

#include <fmt/format.h>

#include "cfuse/constraints/expr.h"
#include "cfuse/constraints/graph.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/joint_frames.h"
#include "cfuse/constraints/kinds/range_slack.h"
#include "cfuse/kernel/residual.h"

namespace cfuse {

template <class Kind>
class JointResidual : public AutoDiffResidual<JointResidual<Kind>> {
 public:
  JointResidual(JointGeometry geometry, std::string type_name)
      : AutoDiffResidual<JointResidual<Kind>>(Kind::kDimension,
                                              {BlockKind::kPose, BlockKind::kPose}),
        geometry_(std::move(geometry)),
        type_name_(std::move(type_name)) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    Kind::Residual(ComputeJointFrames(x[0], x[1], geometry_), geometry_, r);
  }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("{} joint {} -> {}", type_name_, names[0], names[1]);
  }

 private:
  JointGeometry geometry_;
  std::string type_name_;
};

// The joint variable q (one row): angle about the axis (rad) or displacement along it (m). An
// angle is reported on the branch (centre - π, centre + π]: 0 by default, the middle of the
// limits for a limited joint, so that a range past π (Panda's joint 6, [-0.02, 3.75]) reads
// 3.28 where the principal branch would say -3.0.
class JointValueFunction : public AutoDiffResidual<JointValueFunction> {
 public:
  JointValueFunction(JointGeometry geometry, bool prismatic, double centre = 0)
      : AutoDiffResidual(1, {BlockKind::kPose, BlockKind::kPose}),
        geometry_(std::move(geometry)),
        prismatic_(prismatic),
        centre_(centre) {}

  // The branch centre for joint `j`: the middle of its limits, or 0.
  static double BranchCentre(const Joint& j) {
    return j.limits && !ModelOf(j.type).VariableIsLength() ? 0.5 * (j.limits->first + j.limits->second)
                                                       : 0.0;
  }

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const JointFrames<T> f = ComputeJointFrames(x[0], x[1], geometry_);
    r[0] = prismatic_ ? PrismaticDisplacement(f, geometry_, 0.0)
                      : T(centre_) + RevoluteAngle(f, geometry_, centre_);
  }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("joint variable {} -> {}", names[0], names[1]);
  }

 private:
  JointGeometry geometry_;
  bool prismatic_;
  double centre_;
};

// q in [lower, upper] in the product form of range_slack.h, on the slots (parent, child,
// slack). For a revolute joint q is measured from the middle of the range and wrapped, so
// the atan2 branch cut sits half a turn away from the range's centre, outside the range.
class JointLimitResidual : public AutoDiffResidual<JointLimitResidual> {
 public:
  JointLimitResidual(JointGeometry geometry, bool prismatic, double lower, double upper)
      : AutoDiffResidual(1, {BlockKind::kPose, BlockKind::kPose, BlockKind::kSlack}),
        geometry_(std::move(geometry)),
        prismatic_(prismatic),
        mid_(0.5 * (lower + upper)),
        half_(0.5 * (upper - lower)) {}

  template <typename T>
  T Centered(std::span<const BlockState<T>> x) const {
    const JointFrames<T> f = ComputeJointFrames(x[0], x[1], geometry_);
    return prismatic_ ? PrismaticDisplacement(f, geometry_, mid_)
                      : RevoluteAngle(f, geometry_, mid_);
  }

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    r[0] = RangeSlackResidual(Centered(x), 0.0, half_, x[2].slack());
  }

  // The same residual from the joint variable q itself, for a solver that carries it (interp's
  // reduced solver): where the joint holds, Centered is q - mid, an angle wrapped as
  // RevoluteAngle wraps it.
  template <typename T>
  T AtValue(const T& q, const T& slack) const {
    using std::cos, std::sin;
    const T centred = q - T(mid_);
    return RangeSlackResidual(prismatic_ ? centred : T(Atan2(sin(centred), cos(centred))), 0.0,
                              half_, slack);
  }

  std::string Describe(std::span<const std::string> names) const override {
    const Quantity q = prismatic_ ? Quantity::Length() : Quantity::Angle();
    return fmt::format("joint {} -> {} in [{}, {}]", names[0], names[1],
                       FormatQuantity(mid_ - half_, q), FormatQuantity(mid_ + half_, q));
  }

 private:
  JointGeometry geometry_;
  bool prismatic_;
  double mid_, half_;
};

}  // namespace cfuse
