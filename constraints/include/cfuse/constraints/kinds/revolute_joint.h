// Revolute (and continuous) joint: the joint origins coincide and the child's axis stays on
// the parent's axis. With (e1, e2) orthogonal to the axis a in the parent's joint frame:
//   r = [t_c - t_p;  (Rp e1) · (Rc a);  (Rp e2) · (Rc a)]        (5 rows: metres, then sines)
// Three rows for alignment (Rp a × Rc a) would have rank 2. Like any 2-row alignment it also
// vanishes for an anti-parallel axis, half a turn away from the estimate; the estimator works
// locally and never gets there from a consistent start.
#pragma once

#include "cfuse/constraints/kinds/joint_frames.h"

namespace cfuse {

struct RevoluteJoint {
  static constexpr int kDimension = 5;
  template <typename T>
  static void Residual(const JointFrames<T>& f, const JointGeometry& g, T* r) {
    for (int i = 0; i < 3; ++i) r[i] = f.tc[i] - f.tp[i];
    const Vector3<T> axis_c = f.Rc * g.axis.cast<T>();
    r[3] = (f.Rp * g.e1.cast<T>()).dot(axis_c);
    r[4] = (f.Rp * g.e2.cast<T>()).dot(axis_c);
  }
};

}  // namespace cfuse
