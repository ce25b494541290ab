#include "cfuse/geometry/undistort.h"

namespace cfuse {

Eigen::Vector2d UndistortPoint(const Camera& camera, const Eigen::Vector2d& pixel) {
  // Written as OpenCV writes it (calib3d/src/undistort.dispatch.cpp), so that every rounding
  // is the same: the reciprocal focal lengths, the polynomials in Horner's form.
  const auto& k = camera.distortion;
  const double ifx = 1. / camera.fx, ify = 1. / camera.fy;
  const double x0 = (pixel.x() - camera.cx) * ifx, y0 = (pixel.y() - camera.cy) * ify;
  double x = x0, y = y0;
  for (int iteration = 0; iteration < 5; ++iteration) {
    const double r2 = x * x + y * y;
    const double icdist =
        (1 + ((k[7] * r2 + k[6]) * r2 + k[5]) * r2) / (1 + ((k[4] * r2 + k[1]) * r2 + k[0]) * r2);
    if (icdist < 0) return {x0, y0};
    const double dx = 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x) + k[8] * r2 + k[9] * r2 * r2;
    const double dy = k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y + k[10] * r2 + k[11] * r2 * r2;
    x = (x0 - dx) * icdist;
    y = (y0 - dy) * icdist;
  }
  return {x, y};
}

}  // namespace cfuse
