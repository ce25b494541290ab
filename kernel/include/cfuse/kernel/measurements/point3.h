// A measured 3D point (stereo, range sensor) of a model point: r = x_world - z (3 rows,
// metres). The model point is a single-point component (slot: its point block) or a feature
// point of a rigid component (slot: its pose block; x_world = R x_component + t).
#pragma once

#include <fmt/format.h>

#include "cfuse/kernel/residual.h"

namespace cfuse {

class Point3Residual : public AutoDiffResidual<Point3Residual> {
 public:
  // A single-point component.
  explicit Point3Residual(const Eigen::Vector3d& measured)
      : AutoDiffResidual(3, {BlockKind::kPoint}), measured_(measured), on_pose_(false) {}
  // A feature point at `position_in_component` of a rigid component.
  Point3Residual(const Eigen::Vector3d& position_in_component, const Eigen::Vector3d& measured)
      : AutoDiffResidual(3, {BlockKind::kPose}),
        measured_(measured),
        position_(position_in_component),
        on_pose_(true) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> p = ModelPointInWorld(x[0], on_pose_, position_);
    for (int i = 0; i < 3; ++i) r[i] = p[i] - T(measured_[i]);
  }

  // Of a point block, x + δ - z; of a pose, nonlinear in the rotation.
  bool is_linear() const override { return !on_pose_; }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("3D point of {} at [{:.6g}, {:.6g}, {:.6g}] m", names[0], measured_.x(),
                       measured_.y(), measured_.z());
  }

 private:
  Eigen::Vector3d measured_;
  Eigen::Vector3d position_ = Eigen::Vector3d::Zero();
  bool on_pose_;
};

}  // namespace cfuse
