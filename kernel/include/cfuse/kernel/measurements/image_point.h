// A measured 2D image point of a model point: r = Project(x_camera) - uv (2 rows, pixels),
// with the camera of camera.h (pinhole with distortion, or orthographic). The model point is
// a single-point component or a feature point of a rigid component, as in point3.h; the
// viewer frame is the camera frame.
#pragma once

#include <fmt/format.h>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/residual.h"

namespace cfuse {

class ImagePointResidual : public AutoDiffResidual<ImagePointResidual> {
 public:
  ImagePointResidual(const Camera& camera, const Eigen::Vector2d& measured)
      : AutoDiffResidual(2, {BlockKind::kPoint}),
        camera_(camera),
        measured_(measured),
        on_pose_(false) {}
  ImagePointResidual(const Camera& camera, const Eigen::Vector3d& position_in_component,
                     const Eigen::Vector2d& measured)
      : AutoDiffResidual(2, {BlockKind::kPose}),
        camera_(camera),
        measured_(measured),
        position_(position_in_component),
        on_pose_(true) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> p = ModelPointInWorld(x[0], on_pose_, position_);
    const Eigen::Matrix<T, 2, 1> uv = camera_.Project<T>(p);
    r[0] = uv[0] - T(measured_[0]);
    r[1] = uv[1] - T(measured_[1]);
  }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("image point of {} at ({:.6g}, {:.6g}) px", names[0], measured_.x(),
                       measured_.y());
  }

 private:
  Camera camera_;
  Eigen::Vector2d measured_;
  Eigen::Vector3d position_ = Eigen::Vector3d::Zero();
  bool on_pose_;
};

}  // namespace cfuse
