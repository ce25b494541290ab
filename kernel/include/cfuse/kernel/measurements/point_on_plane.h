// A measured 3D point (a range sensor's) on a plane of a rigid component: its signed distance
// from the plane, r = n · (Rᵀ (z - t)) - d (1 row, metres), where n is the plane's unit normal
// and d its offset, both in the component's frame. A range sensor samples surfaces, not
// feature points: which point of the face it saw is unknown, only that it lies on the face.
#pragma once

#include <fmt/format.h>

#include "cfuse/kernel/residual.h"

namespace cfuse {

class PointOnPlaneResidual : public AutoDiffResidual<PointOnPlaneResidual> {
 public:
  // `normal_in_component` is normalised here.
  PointOnPlaneResidual(const Eigen::Vector3d& normal_in_component, double offset,
                       const Eigen::Vector3d& measured_in_world)
      : AutoDiffResidual(1, {BlockKind::kPose}),
        normal_(normal_in_component.normalized()),
        offset_(offset),
        measured_(measured_in_world) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> in_component = x[0].R.transpose() * (measured_.cast<T>() - x[0].t);
    r[0] = normal_.cast<T>().dot(in_component) - T(offset_);
  }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("3D point at [{:.6g}, {:.6g}, {:.6g}] m on a plane of {}", measured_.x(),
                       measured_.y(), measured_.z(), names[0]);
  }

 private:
  Eigen::Vector3d normal_;
  double offset_;
  Eigen::Vector3d measured_;
};

}  // namespace cfuse
