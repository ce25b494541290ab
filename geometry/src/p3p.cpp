#include "cfuse/geometry/p3p.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "cfuse/geometry/undistort.h"

namespace cfuse {
namespace {

// λᵀ B λ = |λ_i y_i − λ_j y_j|² for unit bearings y with y_i·y_j = b.
Eigen::Matrix3d PairForm(int i, int j, double b) {
  Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
  B(i, i) = B(j, j) = 1;
  B(i, j) = B(j, i) = -b;
  return B;
}

// The cofactor matrix (the adjugate's transpose): det(A + γB) = det A + γ Σ cof(A)∘B +
// γ² Σ A∘cof(B) + γ³ det B.
Eigen::Matrix3d Cofactors(const Eigen::Matrix3d& A) {
  Eigen::Matrix3d C;
  C << A.col(1).cross(A.col(2)), A.col(2).cross(A.col(0)), A.col(0).cross(A.col(1));
  return C;
}

// A real root of t³ + p2 t² + p1 t + p0 (Cardano, or the trigonometric form for three real
// roots), polished by two Newton steps.
double RealCubicRoot(double p2, double p1, double p0) {
  const double a = p1 - p2 * p2 / 3, b = (2 * p2 * p2 * p2 - 9 * p2 * p1) / 27 + p0;
  const double disc = b * b / 4 + a * a * a / 27;
  double t;
  if (disc >= 0) {
    const double s = std::sqrt(disc);
    t = std::cbrt(-b / 2 + s) + std::cbrt(-b / 2 - s);
  } else {  // three real roots: a < 0
    const double c = std::clamp(3 * b / (2 * a) * std::sqrt(-3 / a), -1.0, 1.0);
    t = 2 * std::sqrt(-a / 3) * std::cos(std::acos(c) / 3);
  }
  t -= p2 / 3;
  for (int i = 0; i < 2; ++i) {
    const double f = ((t + p2) * t + p1) * t + p0, df = (3 * t + 2 * p2) * t + p1;
    if (df == 0) break;
    t -= f / df;
  }
  return t;
}

}  // namespace

int ThreePointPoses(const std::array<Eigen::Vector3d, 3>& bearings,
                    const std::array<Eigen::Vector3d, 3>& object_points,
                    std::array<Rigid3d, 4>* poses) {
  const auto& y = bearings;
  const auto& x = object_points;
  const Eigen::Vector3d d01 = x[0] - x[1], d02 = x[0] - x[2];
  const double a01 = d01.squaredNorm(), a02 = d02.squaredNorm(), a12 = (x[1] - x[2]).squaredNorm();
  const Eigen::Vector3d normal = d01.cross(d02);
  if (!(normal.squaredNorm() > 1e-12 * a01 * a02)) return 0;  // collinear or coincident
  const Eigen::Matrix3d B01 = PairForm(0, 1, y[0].dot(y[1])), B02 = PairForm(0, 2, y[0].dot(y[2])),
                        B12 = PairForm(1, 2, y[1].dot(y[2]));
  // The depths λ satisfy λᵀ B_ij λ = a_ij; weighting two pairs by the third's a_ij removes the
  // scale: two homogeneous quadrics λᵀ D λ = 0.
  const Eigen::Matrix3d D1 = a12 * B01 - a01 * B12, D2 = a12 * B02 - a02 * B12;
  // A degenerate member of their pencil, det(D1 + γ D2) = 0: the larger of the outer
  // coefficients leads, so that D2 alone (γ = ∞) stays reachable.
  const double c0 = D1.determinant(), c1 = (Cofactors(D1).array() * D2.array()).sum(),
               c2 = (D1.array() * Cofactors(D2).array()).sum(), c3 = D2.determinant();
  Eigen::Matrix3d D0;
  if (std::abs(c3) >= std::abs(c0)) {
    if (c3 == 0) return 0;
    D0 = D1 + RealCubicRoot(c2 / c3, c1 / c3, c0 / c3) * D2;
  } else {
    D0 = RealCubicRoot(c1 / c0, c2 / c0, c3 / c0) * D1 + D2;
  }
  if (!D0.allFinite()) return 0;
  // Rank 2: σa (ea·λ)² + σb (eb·λ)² = 0 with σa > 0 > σb splits into two planes
  // (ea ∓ s eb)·λ = 0, s = √(−σb/σa). Same signs: no real solution.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(D0);
  const Eigen::Vector3d sigma = eig.eigenvalues();  // ascending
  int zero = 0;
  for (int i = 1; i < 3; ++i) {
    if (std::abs(sigma[i]) < std::abs(sigma[zero])) zero = i;
  }
  const int ia = zero == 2 ? 1 : 2, ib = zero == 0 ? 1 : 0;  // σ[ia] ≥ σ[ib]
  if (!(sigma[ia] > 0 && sigma[ib] < 0)) return 0;
  const double s = std::sqrt(-sigma[ib] / sigma[ia]);
  const Eigen::Vector3d ea = eig.eigenvectors().col(ia), eb = eig.eigenvectors().col(ib);
  const Eigen::Matrix3d B_sum = B01 + B02 + B12;
  const double a_sum = a01 + a02 + a12;
  Eigen::Matrix3d XX;
  XX << d01, d02, normal;
  const Eigen::Matrix3d XX_inverse = XX.inverse();
  int count = 0;
  for (const double sign : {1.0, -1.0}) {
    const Eigen::Vector3d u = ea - sign * s * eb;
    // λ_k from the other two, k the largest |u_k|; τ = λ_q / λ_p.
    int k = 0;
    for (int i = 1; i < 3; ++i) {
      if (std::abs(u[i]) > std::abs(u[k])) k = i;
    }
    const int p = (k + 1) % 3, q = (k + 2) % 3;
    Eigen::Matrix<double, 3, 2> M = Eigen::Matrix<double, 3, 2>::Zero();
    M(k, 0) = -u[p] / u[k];
    M(k, 1) = -u[q] / u[k];
    M(p, 0) = M(q, 1) = 1;
    // On the plane D1 and D2 are proportional; the better conditioned one gives τ.
    const Eigen::Matrix2d Q1 = M.transpose() * D1 * M, Q2 = M.transpose() * D2 * M;
    const Eigen::Matrix2d& Q = Q1.squaredNorm() >= Q2.squaredNorm() ? Q1 : Q2;
    // Q11 τ² + 2 Q01 τ + Q00 = 0.
    std::array<double, 2> taus;
    int n_tau = 0;
    if (std::abs(Q(1, 1)) > 1e-14 * Q.cwiseAbs().maxCoeff()) {
      const double disc = Q(0, 1) * Q(0, 1) - Q(0, 0) * Q(1, 1);
      if (disc < -1e-12 * Q(0, 1) * Q(0, 1)) continue;
      const double root = std::sqrt(std::max(0.0, disc));
      // The root without cancellation, and the other from the product of roots.
      const double t1 = Q(0, 1) > 0 ? (-Q(0, 1) - root) / Q(1, 1) : (-Q(0, 1) + root) / Q(1, 1);
      taus[n_tau++] = t1;
      if (t1 != 0) taus[n_tau++] = Q(0, 0) / (Q(1, 1) * t1);
    } else if (Q(0, 1) != 0) {
      taus[n_tau++] = -Q(0, 0) / (2 * Q(0, 1));
    }
    for (int t = 0; t < n_tau; ++t) {
      if (!(taus[t] > 0)) continue;
      const Eigen::Vector3d v = M * Eigen::Vector2d(1, taus[t]);
      const double den = v.dot(B_sum * v);
      if (!(den > 0)) continue;
      Eigen::Vector3d lambda = std::sqrt(a_sum / den) * v;
      if (!(lambda.minCoeff() > 0)) continue;
      // Newton on the three distance equations.
      for (int it = 0; it < 5; ++it) {
        const Eigen::Vector3d r(lambda.dot(B01 * lambda) - a01, lambda.dot(B02 * lambda) - a02,
                                lambda.dot(B12 * lambda) - a12);
        if (r.cwiseAbs().sum() < 1e-14 * a_sum) break;
        Eigen::Matrix3d J;
        J << 2 * (B01 * lambda).transpose(), 2 * (B02 * lambda).transpose(),
            2 * (B12 * lambda).transpose();
        const Eigen::Vector3d step = J.partialPivLu().solve(r);
        if (!step.allFinite()) break;
        lambda -= step;
      }
      if (!(lambda.minCoeff() > 0) || count == 4) continue;
      const Eigen::Vector3d v1 = lambda[0] * y[0] - lambda[1] * y[1],
                            v2 = lambda[0] * y[0] - lambda[2] * y[2];
      Eigen::Matrix3d YY;
      YY << v1, v2, v1.cross(v2);
      const Eigen::Matrix3d R = YY * XX_inverse;
      const Eigen::Vector3d t_vec = lambda[0] * y[0] - R * x[0];
      if (!R.allFinite() || !t_vec.allFinite()) continue;
      (*poses)[count++] = Rigid3d(Eigen::Quaterniond(R).normalized(), t_vec);
    }
  }
  return count;
}

bool PixelBearing(const Camera& camera, const Eigen::Vector2d& pixel, Eigen::Vector3d* bearing) {
  if (camera.model != Camera::Model::kPinhole) return false;
  Eigen::Vector2d xy;
  if (std::all_of(camera.distortion.begin(), camera.distortion.end(),
                  [](double d) { return d == 0; })) {
    xy = {(pixel.x() - camera.cx) / camera.fx, (pixel.y() - camera.cy) / camera.fy};
  } else {
    xy = UndistortPoint(camera, pixel);
  }
  *bearing = Eigen::Vector3d(xy.x(), xy.y(), 1).normalized();
  return true;
}

std::vector<Rigid3d> PosesFromThreeProjections(const Camera& camera,
                                               const std::array<Eigen::Vector3d, 3>& object_points,
                                               const std::array<Eigen::Vector2d, 3>& image_points) {
  std::vector<Rigid3d> poses;
  std::array<Eigen::Vector3d, 3> bearings;
  for (int i = 0; i < 3; ++i) {
    if (!PixelBearing(camera, image_points[i], &bearings[i])) return poses;
  }
  std::array<Rigid3d, 4> found;
  const int n = ThreePointPoses(bearings, object_points, &found);
  poses.assign(found.begin(), found.begin() + n);
  return poses;
}

}  // namespace cfuse
