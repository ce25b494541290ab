// Planar joint (URDF's `planar`): the child turns about the axis a and slides in the plane
// normal to it. Its axis stays on the parent's, and its origin stays in the parent's plane:
//   r = [(Rp e1) · (Rc a);  (Rp e2) · (Rc a);  (Rp a) · (t_c - t_p)]       (3 rows)
#pragma once

#include "cfuse/constraints/kinds/joint_frames.h"

namespace cfuse {

struct PlanarJoint {
  static constexpr int kDimension = 3;
  template <typename T>
  static void Residual(const JointFrames<T>& f, const JointGeometry& g, T* r) {
    const Vector3<T> axis_c = f.Rc * g.axis.cast<T>();
    r[0] = (f.Rp * g.e1.cast<T>()).dot(axis_c);
    r[1] = (f.Rp * g.e2.cast<T>()).dot(axis_c);
    r[2] = (f.Rp * g.axis.cast<T>()).dot(f.tc - f.tp);
  }
};

}  // namespace cfuse
