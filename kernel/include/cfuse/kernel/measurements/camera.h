// Cameras for 2D measurements, in the viewer (camera) frame: x right, y down, z forward.
//
// Pinhole with OpenCV's distortion model (calib3d's projectPoints), for 4, 5, 8, 12 or 14
// coefficients [k1 k2 p1 p2 (k3 (k4 k5 k6 (s1 s2 s3 s4 (τx τy))))] — the tilt (τx, τy) is
// refused by the readers; here any of the first 12 may be given:
//   x' = x/z, y' = y/z, r² = x'² + y'²,
//   radial = (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶),
//   x'' = x' radial + 2 p1 x'y' + p2 (r² + 2x'²) + s1 r² + s2 r⁴,
//   y'' = y' radial + p1 (r² + 2y'²) + 2 p2 x'y' + s3 r² + s4 r⁴,
//   u = fx x'' + cx,  v = fy y'' + cy     (pixels; pixel centres at integer coordinates).
// Orthographic: u = scale x + cx, v = scale y + cy (scale in pixels per metre).
#pragma once

#include <array>
#include <limits>

#include "cfuse/kernel/so3.h"

namespace cfuse {

struct Camera {
  enum class Model { kPinhole, kOrthographic };
  Model model = Model::kPinhole;
  double fx = 1, fy = 1, cx = 0, cy = 0;  // pinhole
  double scale = 1;                       // orthographic, pixels per metre
  int width = 0, height = 0;              // pixels; 0 = unknown
  std::array<double, 12> distortion{};    // k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4

  // Whether any distortion coefficient is non-zero (a pinhole without them projects directly).
  bool Distorted() const {
    for (double d : distortion) {
      if (d != 0) return true;
    }
    return false;
  }

  // Pixel coordinates of a point in the camera frame. A pinhole camera cannot see a point at
  // or behind its centre (z <= 0): the result is then NaN, which the estimator refuses.
  template <typename T>
  Eigen::Matrix<T, 2, 1> Project(const Vector3<T>& p) const {
    if (model == Model::kOrthographic) {
      return {T(scale) * p.x() + T(cx), T(scale) * p.y() + T(cy)};
    }
    if (!(p.z() > T(0))) {
      const T nan = T(std::numeric_limits<double>::quiet_NaN());
      return {nan, nan};
    }
    const T x = p.x() / p.z(), y = p.y() / p.z();
    // Without distortion the terms below add zeros and divide by one: the same values (and
    // derivatives) for every finite point, at a fraction of the work.
    if (!Distorted()) return {T(fx) * x + T(cx), T(fy) * y + T(cy)};
    const T r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
    const auto& d = distortion;
    const T radial = (T(1) + T(d[0]) * r2 + T(d[1]) * r4 + T(d[4]) * r6) /
                     (T(1) + T(d[5]) * r2 + T(d[6]) * r4 + T(d[7]) * r6);
    const T xd = x * radial + T(2 * d[2]) * x * y + T(d[3]) * (r2 + T(2) * x * x) + T(d[8]) * r2 +
                 T(d[9]) * r4;
    const T yd = y * radial + T(d[2]) * (r2 + T(2) * y * y) + T(2 * d[3]) * x * y + T(d[10]) * r2 +
                 T(d[11]) * r4;
    return {T(fx) * xd + T(cx), T(fy) * yd + T(cy)};
  }
};

}  // namespace cfuse
