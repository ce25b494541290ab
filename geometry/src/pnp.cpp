#include "cfuse/geometry/pnp.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "cfuse/geometry/p3p.h"
#include "cfuse/geometry/undistort.h"
#include "cfuse/kernel/so3.h"

namespace cfuse {
namespace {

constexpr int kMaxTriples = 200;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Normalised image coordinates (x/z, y/z) of the pixels, the lens distortion undone.
std::vector<Eigen::Vector2d> Normalised(const Camera& camera,
                                        const std::vector<Eigen::Vector2d>& pixels) {
  const bool distorted = std::any_of(camera.distortion.begin(), camera.distortion.end(),
                                     [](double d) { return d != 0; });
  std::vector<Eigen::Vector2d> xy;
  xy.reserve(pixels.size());
  for (const Eigen::Vector2d& p : pixels) {
    xy.push_back(distorted ? UndistortPoint(camera, p)
                           : Eigen::Vector2d((p.x() - camera.cx) / camera.fx,
                                             (p.y() - camera.cy) / camera.fy));
  }
  return xy;
}

// The problem in normalised coordinates, errors scaled back to pixels by the focal lengths.
struct Problem {
  const Camera& camera;
  const std::vector<Eigen::Vector3d>& object;
  std::vector<Eigen::Vector2d> xy;

  // Squared reprojection error of correspondence i under camera_from_object; infinite behind
  // the camera.
  double SquaredError(const Rigid3d& camera_from_object, size_t i) const {
    const Eigen::Vector3d p = camera_from_object * object[i];
    if (!(p.z() > 0)) return kInf;
    const double ex = camera.fx * (p.x() / p.z() - xy[i].x());
    const double ey = camera.fy * (p.y() / p.z() - xy[i].y());
    return ex * ex + ey * ey;
  }

  // The h-th smallest squared error over all n correspondences, h = ⌊(n + 4) / 2⌋: the median,
  // moved up so that the three points a P3P hypothesis fits exactly never make up half of the
  // order statistic (Rousseeuw & Leroy's h = ⌊(n + p + 1) / 2⌋ for p = 3).
  double MedianSquaredError(const Rigid3d& camera_from_object, std::vector<double>* scratch) const {
    scratch->resize(object.size());
    for (size_t i = 0; i < object.size(); ++i) (*scratch)[i] = SquaredError(camera_from_object, i);
    const size_t h = std::min((object.size() + 4) / 2, object.size());
    const auto middle = scratch->begin() + static_cast<std::ptrdiff_t>(h - 1);
    std::nth_element(scratch->begin(), middle, scratch->end());
    return *middle;
  }

  double Cost(const Rigid3d& camera_from_object, const std::vector<int>& subset) const {
    double cost = 0;
    for (int i : subset) cost += SquaredError(camera_from_object, static_cast<size_t>(i));
    return cost;
  }

  // Levenberg–Marquardt on the reprojection errors of `subset`, the rotation perturbed on the
  // left (R ← exp(δθ) R); a step that puts a point behind the camera is refused like any step
  // that raises the cost.
  void Refine(const std::vector<int>& subset, Rigid3d* camera_from_object) const {
    Rigid3d pose = *camera_from_object;
    double cost = Cost(pose, subset);
    double lambda = 1e-4;
    for (int iteration = 0; iteration < 50 && std::isfinite(cost); ++iteration) {
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      for (int i : subset) {
        const Eigen::Vector3d rotated = pose.rotation * object[static_cast<size_t>(i)];
        const Eigen::Vector3d p = rotated + pose.translation;
        const double iz = 1 / p.z();
        const Eigen::Vector2d r(camera.fx * (p.x() * iz - xy[static_cast<size_t>(i)].x()),
                                camera.fy * (p.y() * iz - xy[static_cast<size_t>(i)].y()));
        Eigen::Matrix<double, 2, 3> d_projection_d_p;
        d_projection_d_p << camera.fx * iz, 0, -camera.fx * p.x() * iz * iz,  //
            0, camera.fy * iz, -camera.fy * p.y() * iz * iz;
        Eigen::Matrix<double, 3, 6> d_p_d_step;
        d_p_d_step << -Hat<double>(rotated), Eigen::Matrix3d::Identity();
        const Eigen::Matrix<double, 2, 6> J = d_projection_d_p * d_p_d_step;
        H.noalias() += J.transpose() * J;
        g.noalias() += J.transpose() * r;
      }
      bool improved = false;
      while (lambda < 1e12) {
        Eigen::Matrix<double, 6, 6> damped = H;
        damped.diagonal() *= 1 + lambda;
        const Eigen::Matrix<double, 6, 1> step = damped.ldlt().solve(-g);
        const Eigen::Vector3d turn = step.head<3>();
        const double angle = turn.norm();
        const Eigen::Quaterniond q =
            angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, turn / angle))
                      : Eigen::Quaterniond::Identity();
        const Rigid3d trial((q * pose.rotation).normalized(), pose.translation + step.tail<3>());
        const double trial_cost = Cost(trial, subset);
        if (trial_cost < cost) {
          const bool converged = cost - trial_cost <= 1e-12 * cost || step.norm() < 1e-14;
          pose = trial;
          cost = trial_cost;
          lambda = std::max(lambda / 10, 1e-12);
          improved = !converged;
          break;
        }
        lambda *= 10;
      }
      if (!improved) break;
    }
    *camera_from_object = pose;
  }

  // The correspondences within 2.5 robust standard deviations of camera_from_object, the
  // deviation from the median squared error (Rousseeuw & Leroy's small-sample factor), kept
  // above a millionth of a pixel so that exact data keep every point.
  std::vector<int> Inliers(const Rigid3d& camera_from_object, std::vector<double>* scratch) const {
    const double median = MedianSquaredError(camera_from_object, scratch);
    const double n = static_cast<double>(object.size());
    const double sigma = 1.4826 * (1 + 5 / std::max(n - 6, 1.0)) * std::sqrt(median);
    const double gate = std::max(2.5 * sigma, 1e-6);
    std::vector<int> inliers;
    for (size_t i = 0; i < object.size(); ++i) {
      if (SquaredError(camera_from_object, i) <= gate * gate)
        inliers.push_back(static_cast<int>(i));
    }
    return inliers;
  }
};

// The triples the hypotheses come from: all of them for up to kMaxTriples, else kMaxTriples
// distinct ones drawn with a fixed seed, so that the result is reproducible.
std::vector<std::array<int, 3>> Triples(int n) {
  std::vector<std::array<int, 3>> triples;
  const double all = static_cast<double>(n) * (n - 1) * (n - 2) / 6;
  if (all <= kMaxTriples) {
    for (int a = 0; a < n; ++a) {
      for (int b = a + 1; b < n; ++b) {
        for (int c = b + 1; c < n; ++c) triples.push_back({a, b, c});
      }
    }
    return triples;
  }
  std::mt19937 rng(1);
  while (static_cast<int>(triples.size()) < kMaxTriples) {
    std::array<int, 3> t{static_cast<int>(rng() % static_cast<unsigned>(n)),
                         static_cast<int>(rng() % static_cast<unsigned>(n)),
                         static_cast<int>(rng() % static_cast<unsigned>(n))};
    if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) triples.push_back(t);
  }
  return triples;
}

}  // namespace

bool PoseFromProjections(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                         const std::vector<Eigen::Vector2d>& image_points, PnpResult* result) {
  if (camera.model != Camera::Model::kPinhole || object_points.size() < 4 ||
      object_points.size() != image_points.size()) {
    return false;
  }
  for (size_t i = 0; i < object_points.size(); ++i) {
    if (!object_points[i].allFinite() || !image_points[i].allFinite()) return false;
  }
  const Problem problem{camera, object_points, Normalised(camera, image_points)};
  std::vector<Eigen::Vector3d> bearings;
  for (const Eigen::Vector2d& xy : problem.xy) {
    bearings.push_back(Eigen::Vector3d(xy.x(), xy.y(), 1).normalized());
  }

  double best_score = kInf;
  Rigid3d best;
  std::vector<double> scratch;
  for (const std::array<int, 3>& t : Triples(static_cast<int>(object_points.size()))) {
    std::array<Rigid3d, 4> poses;
    const int found =
        ThreePointPoses({bearings[t[0]], bearings[t[1]], bearings[t[2]]},
                        {object_points[t[0]], object_points[t[1]], object_points[t[2]]}, &poses);
    for (int k = 0; k < found; ++k) {
      const double score = problem.MedianSquaredError(poses[k], &scratch);
      if (score < best_score) {
        best_score = score;
        best = poses[k];
      }
    }
  }
  if (!std::isfinite(best_score)) return false;

  // Refined on its inliers, which are then found again from the refined pose: a few rounds
  // settle them.
  std::vector<int> inliers = problem.Inliers(best, &scratch);
  for (int round = 0; round < 3; ++round) {
    problem.Refine(inliers, &best);
    std::vector<int> again = problem.Inliers(best, &scratch);
    if (again == inliers || again.size() < 3) break;
    inliers = std::move(again);
  }
  if (inliers.size() < 3 || !best.translation.allFinite() || !best.rotation.coeffs().allFinite()) {
    return false;
  }
  result->camera_from_object = best;
  result->rms_error = std::sqrt(problem.Cost(best, inliers) / static_cast<double>(inliers.size()));
  result->inliers = std::move(inliers);
  return true;
}

}  // namespace cfuse
