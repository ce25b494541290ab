// Rotations templated on the scalar, so that automatic differentiation (cfuse/kernel/jet.h) passes
// through them. Conventions, used everywhere in cfuse:
//   - rotation matrices act on column vectors: x_in_a = a_R_b * x_in_b;
//   - quaternions are stored [w, x, y, z] (Hamilton, w the real part);
//   - roll-pitch-yaw as in URDF: R = Rz(yaw) * Ry(pitch) * Rx(roll).
//
// Exp maps a rotation vector w (axis * angle, radians) to SO(3) by Rodrigues' formula
//   Exp(w) = I + sin(θ)/θ [w]x + (1 - cos θ)/θ² [w]x²,   θ = |w|,
// switching to its Taylor series near θ = 0, where the closed form is 0/0 and where the
// derivative at w = 0 (the one the estimator needs) would otherwise be undefined.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace cfuse {

template <typename T>
using Vector3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Matrix3 = Eigen::Matrix<T, 3, 3>;
template <typename T>
using Vector4 = Eigen::Matrix<T, 4, 1>;

template <typename T>
Matrix3<T> Hat(const Vector3<T>& w) {
  Matrix3<T> m;
  m << T(0), -w.z(), w.y(),  //
      w.z(), T(0), -w.x(),   //
      -w.y(), w.x(), T(0);
  return m;
}

template <typename T>
Matrix3<T> ExpSO3(const Vector3<T>& w) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta_sq = w.squaredNorm();
  const Matrix3<T> W = Hat(w);
  const Matrix3<T> I = Matrix3<T>::Identity();
  if (theta_sq < T(1e-12)) {
    // Second order is exact to double precision here and has the right first derivative at 0.
    return I + W + T(0.5) * W * W;
  }
  const T theta = sqrt(theta_sq);
  return I + (sin(theta) / theta) * W + ((T(1) - cos(theta)) / theta_sq) * W * W;
}

// The right Jacobian of SO(3): Exp(w + d) ≈ Exp(w) Exp(Jr(w) d) for small d,
//   Jr(w) = I - (1 - cos θ)/θ² [w]x + (θ - sin θ)/θ³ [w]x².
// The estimator uses it to move a covariance from the chart at R to the chart at R Exp(w).
inline Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& w) {
  const double theta_sq = w.squaredNorm();
  const Eigen::Matrix3d W = Hat<double>(w);
  if (theta_sq < 1e-10) return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 6.0;
  const double theta = std::sqrt(theta_sq);
  return Eigen::Matrix3d::Identity() - (1 - std::cos(theta)) / theta_sq * W +
         (theta - std::sin(theta)) / (theta_sq * theta) * W * W;
}

// Its inverse, in closed form (where the solvers need Jr(w)⁻¹ for every pose of every
// iteration): Jr(w)⁻¹ = I + ½ [w]x + (1/θ² - cot(θ/2) / (2θ)) [w]x², defined for θ < 2π.
inline Eigen::Matrix3d InverseRightJacobianSO3(const Eigen::Vector3d& w) {
  const double theta_sq = w.squaredNorm();
  const Eigen::Matrix3d W = Hat<double>(w);
  if (theta_sq < 1e-10) return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 12.0;
  const double theta = std::sqrt(theta_sq);
  const double c = 1 / theta_sq - std::cos(theta / 2) / (2 * theta * std::sin(theta / 2));
  return Eigen::Matrix3d::Identity() + 0.5 * W + c * W * W;
}

// Log of a unit quaternion: its rotation vector, of angle in [0, π].
inline Eigen::Vector3d LogSO3(const Eigen::Quaterniond& q) {
  const double sign = q.w() < 0 ? -1 : 1;  // q and -q are the same rotation
  const Eigen::Vector3d v = sign * q.vec();
  const double w = sign * q.w(), s = v.norm();
  if (s < 1e-8) return (2 / w) * v;  // 2 atan2(s, w) / s = (2 / w)(1 - O(s²))
  return (2 * std::atan2(s, w) / s) * v;
}

// Unit quaternion [w, x, y, z] of a rotation matrix (Shepperd's method: branch on the largest
// of the trace and the diagonal, so that the square root is always of a number >= 1).
template <typename T>
Vector4<T> RotationToQuaternion(const Matrix3<T>& R) {
  using std::sqrt;
  const T trace = R(0, 0) + R(1, 1) + R(2, 2);
  Vector4<T> q;
  if (trace >= R(0, 0) && trace >= R(1, 1) && trace >= R(2, 2)) {
    const T s = sqrt(T(1) + trace) * T(2);  // 4w
    q << T(0.25) * s, (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s, (R(1, 0) - R(0, 1)) / s;
  } else if (R(0, 0) >= R(1, 1) && R(0, 0) >= R(2, 2)) {
    const T s = sqrt(T(1) + R(0, 0) - R(1, 1) - R(2, 2)) * T(2);  // 4x
    q << (R(2, 1) - R(1, 2)) / s, T(0.25) * s, (R(0, 1) + R(1, 0)) / s, (R(0, 2) + R(2, 0)) / s;
  } else if (R(1, 1) >= R(2, 2)) {
    const T s = sqrt(T(1) + R(1, 1) - R(0, 0) - R(2, 2)) * T(2);  // 4y
    q << (R(0, 2) - R(2, 0)) / s, (R(0, 1) + R(1, 0)) / s, T(0.25) * s, (R(1, 2) + R(2, 1)) / s;
  } else {
    const T s = sqrt(T(1) + R(2, 2) - R(0, 0) - R(1, 1)) * T(2);  // 4z
    q << (R(1, 0) - R(0, 1)) / s, (R(0, 2) + R(2, 0)) / s, (R(1, 2) + R(2, 1)) / s, T(0.25) * s;
  }
  return q;
}

// A 3-vector that is zero exactly when R is the identity: twice the vector part of R's
// quaternion taken with w >= 0, i.e. 2 sin(θ/2) * axis. Near the identity it equals the
// rotation vector to first order, so residuals built on it are in radians. Unlike the skew
// part of R (sin θ * axis) it has no spurious zero at θ = π.
template <typename T>
Vector3<T> RotationError(const Matrix3<T>& R) {
  const Vector4<T> q = RotationToQuaternion(R);
  const T sign = q[0] < T(0) ? T(-2) : T(2);
  return sign * q.template tail<3>();
}

// R = Rz(yaw) Ry(pitch) Rx(roll), URDF's convention.
template <typename T>
Matrix3<T> RotationFromRpy(const T& roll, const T& pitch, const T& yaw) {
  using std::cos;
  using std::sin;
  const T cr = cos(roll), sr = sin(roll), cp = cos(pitch), sp = sin(pitch), cy = cos(yaw),
          sy = sin(yaw);
  Matrix3<T> R;
  R << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  return R;
}

// Rotation by `angle` about the unit vector `axis`.
template <typename T>
Matrix3<T> RotationAboutAxis(const Vector3<T>& axis, const T& angle) {
  return ExpSO3<T>(axis * angle);
}

// Two unit vectors completing the unit vector n to a right-handed orthonormal basis
// (e1, e2, n): e1 = normalize(n x h), e2 = n x e1 with a fixed helper h. No smooth choice exists
// for every n (the hairy ball theorem), so the helper switches from h0 to h1 when n comes
// within ~25 degrees of h0. Both helpers are "irrational" directions, so the switch never falls
// on the axis-aligned or 45-degree directions that models are full of: residuals built on the
// basis are smooth there (at a switch they stay consistent with their own Jacobian, and their
// zero set does not change).
template <typename T>
void OrthonormalComplement(const Vector3<T>& n, Vector3<T>* e1, Vector3<T>* e2) {
  using std::abs;
  const Vector3<T> h0 = Vector3<T>(T(1), T(2), T(3)) / T(std::sqrt(14.0));
  const Vector3<T> h1 = Vector3<T>(T(-4), T(3), T(0)) / T(5);
  const Vector3<T>& helper = abs(n.dot(h0)) > T(0.9) ? h1 : h0;
  *e1 = n.cross(helper).normalized();
  *e2 = n.cross(*e1);
}

}  // namespace cfuse
