// Spherical (ball) joint: the joint origins coincide. r = t_c - t_p (3 rows, metres).
#pragma once

#include "cfuse/constraints/kinds/joint_frames.h"

namespace cfuse {

struct SphericalJoint {
  static constexpr int kDimension = 3;
  template <typename T>
  static void Residual(const JointFrames<T>& f, const JointGeometry&, T* r) {
    for (int i = 0; i < 3; ++i) r[i] = f.tc[i] - f.tp[i];
  }
};

}  // namespace cfuse
