// A rigid component's pose (or only its position or orientation) known in the world:
//   position:    r = t - t*                              (3 rows, metres)
//   orientation: r = RotationError(R*ᵀ R)                (3 rows, radians; cfuse/kernel/so3.h)
#pragma once

#include <fmt/format.h>

#include "cfuse/kernel/residual.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

class FixPoseResidual : public AutoDiffResidual<FixPoseResidual> {
 public:
  FixPoseResidual(const Rigid3d& world_from_component, bool position, bool orientation)
      : AutoDiffResidual((position ? 3 : 0) + (orientation ? 3 : 0), {BlockKind::kPose}),
        target_(world_from_component),
        position_(position),
        orientation_(orientation) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    int row = 0;
    if (orientation_) {
      const Vector3<T> e =
          RotationError<T>(target_.RotationMatrix().transpose().cast<T>() * x[0].R);
      for (int i = 0; i < 3; ++i) r[row++] = e[i];
    }
    if (position_) {
      for (int i = 0; i < 3; ++i) r[row++] = x[0].t[i] - T(target_.translation[i]);
    }
  }

  const Rigid3d& target() const { return target_; }
  bool fixes_position() const { return position_; }
  bool fixes_orientation() const { return orientation_; }

  std::string Describe(std::span<const std::string> names) const override {
    const Eigen::Vector3d t = target_.translation;
    const Eigen::Quaterniond q = target_.rotation;
    std::string s = fmt::format("fixed {}", names[0]);
    if (position_) s += fmt::format(" at [{:.6g}, {:.6g}, {:.6g}] m", t.x(), t.y(), t.z());
    if (orientation_) {
      s += fmt::format("{}orientation [w x y z] = [{:.6g}, {:.6g}, {:.6g}, {:.6g}]",
                       position_ ? ", " : " ", q.w(), q.x(), q.y(), q.z());
    }
    return s;
  }

 private:
  Rigid3d target_;
  bool position_, orientation_;
};

}  // namespace cfuse
