// A mimic joint (URDF's <mimic>): the follower's variable is an affine function of the
// leader's, q_f = multiplier * q_l + offset (one row; for a revolute follower the difference is
// wrapped to (-π, π], so that the residual is continuous across a turn). Slots: the distinct
// pose blocks of the two joints, 2 to 4 (two fingers of one gripper share their parent).
#pragma once

#include <fmt/format.h>

#include <cmath>

#include "cfuse/constraints/kinds/joint_frames.h"

namespace cfuse {

class MimicResidual : public AutoDiffResidual<MimicResidual> {
 public:
  struct Side {
    JointGeometry geometry;
    bool prismatic = false;
    int parent_slot = 0, child_slot = 1;  // into the slots
  };

  MimicResidual(Side follower, Side leader, int slots, double multiplier, double offset)
      : AutoDiffResidual(1, std::vector<BlockKind>(slots, BlockKind::kPose)),
        follower_(std::move(follower)),
        leader_(std::move(leader)),
        multiplier_(multiplier),
        offset_(offset) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    using std::cos, std::sin;
    const T d = Value(follower_, x) - (T(multiplier_) * Value(leader_, x) + T(offset_));
    if (follower_.prismatic) {
      r[0] = d;
    } else {
      r[0] = Atan2(sin(d), cos(d));
    }
  }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("joint {} -> {} = {} * joint {} -> {} + {}", names[follower_.parent_slot],
                       names[follower_.child_slot], multiplier_, names[leader_.parent_slot],
                       names[leader_.child_slot], offset_);
  }

 private:
  template <typename T>
  static T Value(const Side& s, std::span<const BlockState<T>> x) {
    const JointFrames<T> f = ComputeJointFrames(x[s.parent_slot], x[s.child_slot], s.geometry);
    return s.prismatic ? PrismaticDisplacement(f, s.geometry, 0.0)
                       : RevoluteAngle(f, s.geometry, 0.0);
  }

  Side follower_, leader_;
  double multiplier_, offset_;
};

}  // namespace cfuse
