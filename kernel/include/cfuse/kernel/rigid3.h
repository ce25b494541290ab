// Rigid transforms in double precision: the storage type of every pose in cfuse.
//
// A Rigid3d named a_from_b (or a_T_b) maps coordinates in frame b to frame a:
//   x_in_a = a_from_b.rotation * x_in_b + a_from_b.translation.
// A component's pose is world_from_component. Quaternions are Eigen's (stored x,y,z,w in
// memory) but are written to files as [w, x, y, z].
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cfuse/kernel/so3.h"

namespace cfuse {

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& r, const Eigen::Vector3d& t) : rotation(r), translation(t) {}
  Rigid3d(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) : rotation(R), translation(t) {}

  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return rotation * x + translation; }
  // a_from_b * b_from_c = a_from_c.
  Rigid3d operator*(const Rigid3d& b_from_c) const {
    return Rigid3d(rotation * b_from_c.rotation, rotation * b_from_c.translation + translation);
  }
  Rigid3d Inverse() const {
    const Eigen::Quaterniond inv = rotation.conjugate();
    return Rigid3d(inv, -(inv * translation));
  }

  static Rigid3d FromXyzRpy(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy) {
    return Rigid3d(RotationFromRpy<double>(rpy.x(), rpy.y(), rpy.z()), xyz);
  }
};

}  // namespace cfuse
