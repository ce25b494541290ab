// Prismatic joint: the frames keep their relative orientation and the child's origin moves
// only along the parent's axis a:
//   r = [RotationError(Rpᵀ Rc);  (Rp e1) · (t_c - t_p);  (Rp e2) · (t_c - t_p)]   (3 + 2 rows)
#pragma once

#include "cfuse/constraints/kinds/joint_frames.h"

namespace cfuse {

struct PrismaticJoint {
  static constexpr int kDimension = 5;
  template <typename T>
  static void Residual(const JointFrames<T>& f, const JointGeometry& g, T* r) {
    const Vector3<T> e = RotationError<T>(f.Rp.transpose() * f.Rc);
    for (int i = 0; i < 3; ++i) r[i] = e[i];
    const Vector3<T> d = f.tc - f.tp;
    r[3] = (f.Rp * g.e1.cast<T>()).dot(d);
    r[4] = (f.Rp * g.e2.cast<T>()).dot(d);
  }
};

}  // namespace cfuse
