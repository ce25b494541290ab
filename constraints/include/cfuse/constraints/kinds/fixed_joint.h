// Fixed joint: the two joint frames coincide.
//   r = [RotationError(Rpᵀ Rc);  t_c - t_p]          (6 rows: radians, then metres)
#pragma once

#include "cfuse/constraints/kinds/joint_frames.h"

namespace cfuse {

struct FixedJoint {
  static constexpr int kDimension = 6;
  template <typename T>
  static void Residual(const JointFrames<T>& f, const JointGeometry&, T* r) {
    const Vector3<T> e = RotationError<T>(f.Rp.transpose() * f.Rc);
    for (int i = 0; i < 3; ++i) r[i] = e[i];
    for (int i = 0; i < 3; ++i) r[3 + i] = f.tc[i] - f.tp[i];
  }
};

}  // namespace cfuse
