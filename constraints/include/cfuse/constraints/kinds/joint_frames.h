// Joint frames seen from both sides of a joint (graph.h, Joint):
//   world_from_joint_p = world_from_parent * parent_from_joint   (frame fixed on the parent)
//   world_from_joint_c = world_from_child  * child_from_joint    (frame fixed on the child)
// Every joint kind is a residual on these two frames: (p^-1 c) must be a Motion(q) of its kind.
// `axis` is the unit joint axis in the joint frame; (e1, e2, axis) is right-handed.
#pragma once

#include "cfuse/kernel/residual.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

struct JointGeometry {
  Rigid3d parent_from_joint;
  Rigid3d child_from_joint;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  Eigen::Vector3d e1, e2;

  JointGeometry(const Rigid3d& p, const Rigid3d& c, const Eigen::Vector3d& a)
      : parent_from_joint(p), child_from_joint(c), axis(a.normalized()) {
    OrthonormalComplement<double>(axis, &e1, &e2);
  }
};

template <typename T>
struct JointFrames {
  Matrix3<T> Rp, Rc;  // world_R_joint_p, world_R_joint_c
  Vector3<T> tp, tc;  // joint origins in the world, from each side
};

template <typename T>
JointFrames<T> ComputeJointFrames(const BlockState<T>& parent, const BlockState<T>& child,
                                  const JointGeometry& g) {
  JointFrames<T> f;
  f.Rp = parent.R * g.parent_from_joint.RotationMatrix().cast<T>();
  f.tp = parent.R * g.parent_from_joint.translation.cast<T>() + parent.t;
  f.Rc = child.R * g.child_from_joint.RotationMatrix().cast<T>();
  f.tc = child.R * g.child_from_joint.translation.cast<T>() + child.t;
  return f;
}

// The joint variable: the angle of the child frame about the axis relative to the parent
// frame, shifted by -offset and wrapped to (-π, π] (revolute, continuous), or the
// displacement along the axis minus offset (prismatic).
template <typename T>
T RevoluteAngle(const JointFrames<T>& f, const JointGeometry& g, double offset) {
  Matrix3<T> R = f.Rp.transpose() * f.Rc;
  if (offset != 0) R = RotationAboutAxis<double>(g.axis, -offset).cast<T>() * R;
  const Vector3<T> e1 = g.e1.cast<T>();
  const Vector3<T> r1 = R * e1;
  return Atan2(g.e2.cast<T>().dot(r1), e1.dot(r1));
}

template <typename T>
T PrismaticDisplacement(const JointFrames<T>& f, const JointGeometry& g, double offset) {
  return g.axis.cast<T>().dot(f.Rp.transpose() * (f.tc - f.tp)) - T(offset);
}

}  // namespace cfuse
