#include "cfuse/interp/closed_form_pose.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "cfuse/kernel/svd.h"

namespace cfuse {
namespace {

// Columns minus their mean; the mean in *centre.
Eigen::Matrix3Xd Centred(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d* centre) {
  Eigen::Matrix3Xd a(3, points.size());
  for (size_t i = 0; i < points.size(); ++i) a.col(i) = points[i];
  *centre = a.rowwise().mean();
  return a.colwise() - *centre;
}

}  // namespace

bool AbsoluteOrientation(const std::vector<Eigen::Vector3d>& from,
                         const std::vector<Eigen::Vector3d>& to, Rigid3d* result) {
  const int n = static_cast<int>(from.size());
  if (n < 3 || to.size() != from.size()) return false;
  // Umeyama's least-squares rotation without scale, in 3 x 3 sums: the interpretation's seeds
  // call this for every triple they try. (Eigen::umeyama and an SVD of the 3 x n points give
  // the same, but their templates were two thirds of this file's compile time.)
  Eigen::Vector3d centre_from = Eigen::Vector3d::Zero(), centre_to = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    centre_from += from[i];
    centre_to += to[i];
  }
  centre_from /= n;
  centre_to /= n;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero(), cross = Eigen::Matrix3d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d a = from[i] - centre_from;
    scatter += a * a.transpose();
    cross += (to[i] - centre_to) * a.transpose();
  }
  // Collinear (or coincident) when the scatter's second eigenvalue vanishes against its first.
  // From its invariants, trace = Σ λ and minors = Σ λi λj (i < j): λ1 λ2 <= minors <= 3 λ1 λ2
  // and λ1 <= trace <= 3 λ1, so minors / trace² is λ2 / λ1 within a factor of 9, without an
  // eigensolver (a Jacobi SVD was half this function's time) and exact to rounding for
  // points on a line (a closed-form eigensolver is not).
  const double trace = scatter.trace();
  const double minors = scatter(0, 0) * scatter(1, 1) - scatter(0, 1) * scatter(1, 0) +
                        scatter(0, 0) * scatter(2, 2) - scatter(0, 2) * scatter(2, 0) +
                        scatter(1, 1) * scatter(2, 2) - scatter(1, 2) * scatter(2, 1);
  if (!(minors > 1e-12 * trace * trace)) return false;
  // R = U S Vᵀ from cross = U D Vᵀ, S = diag(1, 1, ±1) so that R is a rotation.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d S = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S[2] = -1;
  const Eigen::Matrix3d R = svd.matrixU() * S.asDiagonal() * svd.matrixV().transpose();
  *result = Rigid3d(R, centre_to - R * centre_from);
  return true;
}

bool OrthographicPose(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                      const std::vector<Eigen::Vector2d>& image_points, double depth,
                      Rigid3d* camera_from_object) {
  const int n = static_cast<int>(object_points.size());
  if (camera.model != Camera::Model::kOrthographic || n < 3 ||
      image_points.size() != object_points.size() || !(camera.scale > 0)) {
    return false;
  }
  Eigen::Vector3d X_centre;
  const Eigen::Matrix3Xd X = Centred(object_points, &X_centre);
  // Image points in metres on the image plane, centred.
  Eigen::Matrix2Xd p(2, n);
  for (int i = 0; i < n; ++i) {
    p.col(i) = (image_points[i] - Eigen::Vector2d(camera.cx, camera.cy)) / camera.scale;
  }
  const Eigen::Vector2d p_centre = p.rowwise().mean();
  p.colwise() -= p_centre;

  // The object's principal axes: E (3 x 3, columns by decreasing spread).
  // X = E S Wᵀ, computed as the SVD of Xᵀ = W S Eᵀ.
  const SingularValueDecomposition shape = ComputeSvd(X.transpose(), SingularVectors::kFullV);
  const Eigen::Vector3d spread = shape.singular_values;
  if (!(spread[1] > 1e-6 * std::max(spread[0], 1e-12))) return false;  // collinear
  const bool planar = !(spread[2] > 1e-6 * spread[0]);
  if (!planar && n < 4) return false;

  Eigen::Matrix3d R;
  if (!planar) {
    // The affine camera M (2 x 3) with p ≈ M X, then its nearest pair of orthonormal rows.
    const Eigen::Matrix<double, 2, 3> M = p * X.transpose() * (X * X.transpose()).inverse();
    const SingularValueDecomposition svd = ComputeSvd(M, SingularVectors::kThinUFullV);
    const Eigen::Matrix<double, 2, 3> rows = svd.U * svd.V.leftCols<2>().transpose();
    R.row(0) = rows.row(0);
    R.row(1) = rows.row(1);
    R.row(2) = rows.row(0).cross(rows.row(1));
  } else {
    // In the plane's basis E2 = E.leftCols(2): X = E2 q, p ≈ B q with B = Π R E2 (2 x 2).
    // The columns of R E2 are orthonormal 3-vectors whose first two entries are B's columns;
    // their third entries z follow from unit length and orthogonality, up to one sign.
    const Eigen::Matrix<double, 3, 2> E2 = shape.V.leftCols<2>();
    const Eigen::Matrix2Xd q = E2.transpose() * X;
    Eigen::Matrix2d B = p * q.transpose() * (q * q.transpose()).inverse();
    // Nearest B whose columns can be completed: singular values clamped to at most 1.
    const SingularValueDecomposition svd = ComputeSvd(B, SingularVectors::kThinUFullV);
    const Eigen::Vector2d sv = svd.singular_values.cwiseMin(1.0);
    B = svd.U * sv.asDiagonal() * svd.V.transpose();
    // Third entries z with |b_j|² + z_j² = 1 and b_1·b_2 + z_1 z_2 = 0: z = (1 - B'B) split by
    // its rank-one factor, i.e. G = I - BᵀB = z zᵀ.
    const Eigen::Matrix2d G = Eigen::Matrix2d::Identity() - B.transpose() * B;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(G);
    const Eigen::Vector2d z =
        std::sqrt(std::max(0.0, eig.eigenvalues()[1])) * eig.eigenvectors().col(1);
    Eigen::Matrix<double, 3, 2> C;
    C.topRows<2>() = B;
    C.row(2) = z.transpose();
    // Re-orthonormalise the columns (roundoff, and the clamping above), then complete with the
    // normal. Of the two mirror images (z and -z), take the one whose plane normal faces the
    // camera (negative z in the camera frame, which looks along +z).
    Eigen::Vector3d c0 = C.col(0).normalized();
    Eigen::Vector3d c1 = (C.col(1) - c0.dot(C.col(1)) * c0).normalized();
    Eigen::Vector3d normal = c0.cross(c1);
    if (normal.z() > 0) {
      c0.z() = -c0.z();
      c1.z() = -c1.z();
      normal = c0.cross(c1);
    }
    Eigen::Matrix3d RE;  // R E, with E = [E2, e3] and e3 = e1 x e2
    RE << c0, c1, normal;
    Eigen::Matrix3d E;
    E << E2, E2.col(0).cross(E2.col(1));
    R = RE * E.transpose();
  }
  if (!R.allFinite()) return false;
  // Translation: the centroid lands on the measured centroid, at the given depth.
  const Eigen::Vector3d centre_in_camera = R * X_centre;
  const Eigen::Vector3d t(p_centre.x() - centre_in_camera.x(), p_centre.y() - centre_in_camera.y(),
                          depth - centre_in_camera.z());
  *camera_from_object = Rigid3d(Eigen::Quaterniond(R).normalized(), t);
  return true;
}

}  // namespace cfuse
