// A measured image segment of a model edge (Lowe 1992): the perpendicular distances, in
// pixels, of the measured segment's two end points from the line through the projections of
// the edge's two model points (2 rows). The measured ends need not correspond to the model
// points: a segment broken by occlusion or detection still measures the line, and only the
// direction across it. The model edge lies on one rigid component (component coordinates of its
// two points); the viewer frame is the camera frame.
//
// The projection is of the end points (a pinhole camera's image of a 3D line is straight when
// the lens has no distortion; with distortion the line through the two projected ends is its
// chord). The Jacobian comes from automatic differentiation, like every residual's.
#pragma once

#include <fmt/format.h>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/residual.h"

namespace cfuse {

class ImageSegmentResidual : public AutoDiffResidual<ImageSegmentResidual> {
 public:
  ImageSegmentResidual(const Camera& camera, const Eigen::Vector3d& a_in_component,
                       const Eigen::Vector3d& b_in_component, const Eigen::Vector2d& measured_a,
                       const Eigen::Vector2d& measured_b)
      : AutoDiffResidual(2, {BlockKind::kPose}),
        camera_(camera),
        a_(a_in_component),
        b_(b_in_component),
        measured_a_(measured_a),
        measured_b_(measured_b) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Eigen::Matrix<T, 2, 1> pa = camera_.Project<T>(ModelPointInWorld(x[0], true, a_));
    const Eigen::Matrix<T, 2, 1> pb = camera_.Project<T>(ModelPointInWorld(x[0], true, b_));
    const Eigen::Matrix<T, 2, 1> d = pb - pa;
    using std::sqrt;
    const T length = sqrt(d.squaredNorm());
    // The unit normal of the projected line; the signed distance of each measured end from it.
    const Eigen::Matrix<T, 2, 1> n(-d.y() / length, d.x() / length);
    r[0] = n.dot(measured_a_.cast<T>() - pa);
    r[1] = n.dot(measured_b_.cast<T>() - pa);
  }

  const Eigen::Vector2d& measured_a() const { return measured_a_; }
  const Eigen::Vector2d& measured_b() const { return measured_b_; }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("image segment of an edge of {} at ({:.6g}, {:.6g})-({:.6g}, {:.6g}) px",
                       names[0], measured_a_.x(), measured_a_.y(), measured_b_.x(),
                       measured_b_.y());
  }

 private:
  Camera camera_;
  Eigen::Vector3d a_, b_;
  Eigen::Vector2d measured_a_, measured_b_;
};

}  // namespace cfuse
