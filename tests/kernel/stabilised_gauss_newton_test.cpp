// Lowe's stabilised Gauss-Newton (1992, section 4) and the kernel's iterated update with a
// prior are one computation. Lowe solves, each iteration, the normal equations of the
// linearised measurements stacked on the prior's rows,
//
//   [ J ] δ = [ e      ]        (J, e whitened by the measurement noise; W = P0^{-1/2};
//   [ W ]     [ W (d)  ]         d the step back to the prior's mean, here -x)
//
// that is (JᵀJ + WᵀW) δ = Jᵀe + WᵀW d, and moves x by δ. The tracker instead fuses each
// matched segment into a Gaussian state that starts as the prediction (cfuse/kernel/estimator.h:
// FuseSequence with gauss_newton_from_start, each pass linearising every factor about the
// previous estimate). This test runs both on image segments of a box and asserts that they
// agree pass by pass, at convergence, and in the covariance, (JᵀJ + WᵀW)⁻¹. Lowe's side is
// written out here with finite-difference Jacobians, independent of the kernel's automatic
// differentiation.
#include <catch2/catch.hpp>
#include <random>

#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/image_segment.h"

namespace cfuse {
namespace {

struct Problem {
  std::vector<Block> blocks = {{BlockKind::kPose, 0, 0, "box"}};
  Camera camera;
  std::vector<Factor> factors;
  double pixel_sigma = 0.5;
  Values prior_mean;
  Eigen::Matrix<double, 6, 1> prior_sigma;  // rotation (rad) then translation (m)

  // The whitened residuals of every factor at prior ⊞ x.
  Eigen::VectorXd Residuals(const Eigen::Matrix<double, 6, 1>& x) const {
    Values at = prior_mean;
    Retract(blocks, x, &at);
    Eigen::VectorXd out(2 * factors.size()), r;
    for (size_t k = 0; k < factors.size(); ++k) {
      EvaluateResidual(*factors[k].residual, blocks, factors[k].blocks, at, &r, nullptr);
      out.segment<2>(2 * k) = r / pixel_sigma;
    }
    return out;
  }
};

Problem MakeProblem(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  Problem p;
  p.camera.fx = p.camera.fy = 800;
  p.camera.cx = 320;
  p.camera.cy = 240;
  p.camera.width = 640;
  p.camera.height = 480;
  // The box 0.3 x 0.2 x 0.15 m, 1.2 m in front of the camera, turned to show three faces.
  const Rigid3d truth(Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 1, 0.3).normalized()) *
                          Eigen::Quaterniond::Identity(),
                      Eigen::Vector3d(-0.1, -0.05, 1.2));
  std::vector<Eigen::Vector3d> corners;
  for (int i = 0; i < 8; ++i)
    corners.emplace_back(0.3 * (i & 1), 0.2 * (i >> 1 & 1), 0.15 * (i >> 2));
  const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                            {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  for (const auto& e : edges) {
    const Eigen::Vector3d& A = corners[e[0]];
    const Eigen::Vector3d& B = corners[e[1]];
    // A segment over the middle 60 % of the edge's image, each end off the line by the noise.
    const Eigen::Vector2d a = p.camera.Project<double>(truth * A);
    const Eigen::Vector2d b = p.camera.Project<double>(truth * B);
    const Eigen::Vector2d normal = Eigen::Vector2d(a.y() - b.y(), b.x() - a.x()).normalized();
    const Eigen::Vector2d s = a + 0.2 * (b - a) + p.pixel_sigma * n(rng) * normal;
    const Eigen::Vector2d t = a + 0.8 * (b - a) + p.pixel_sigma * n(rng) * normal;
    p.factors.push_back({std::make_shared<ImageSegmentResidual>(p.camera, A, B, s, t),
                         {0},
                         p.pixel_sigma * p.pixel_sigma * Eigen::Matrix2d::Identity(),
                         "edge"});
  }
  // The prediction: 3 degrees and 2 cm off, with a prior of 0.05 rad and 0.03 m.
  p.prior_sigma << 0.05, 0.05, 0.05, 0.03, 0.03, 0.03;
  p.prior_mean.poses = {truth};
  Eigen::Matrix<double, 6, 1> off;
  off << 0.03, -0.04, 0.02, 0.015, -0.01, 0.012;
  Retract(p.blocks, off, &p.prior_mean);
  return p;
}

// One iteration of Lowe's stabilised Gauss-Newton from x (tangent coordinates at the prior's
// mean), with central-difference Jacobians.
Eigen::Matrix<double, 6, 1> LoweStep(const Problem& p, const Eigen::Matrix<double, 6, 1>& x,
                                     Eigen::Matrix<double, 6, 6>* information) {
  const Eigen::VectorXd r = p.Residuals(x);
  Eigen::MatrixXd J(r.size(), 6);
  for (int k = 0; k < 6; ++k) {
    Eigen::Matrix<double, 6, 1> h = Eigen::Matrix<double, 6, 1>::Zero();
    h[k] = 1e-6;
    J.col(k) = (p.Residuals(x + h) - p.Residuals(x - h)) / 2e-6;
  }
  const Eigen::Matrix<double, 6, 6> WtW = p.prior_sigma.cwiseAbs2().cwiseInverse().asDiagonal();
  const Eigen::VectorXd e = -r;              // what the step should remove
  const Eigen::Matrix<double, 6, 1> d = -x;  // back to the prior's mean
  *information = J.transpose() * J + WtW;
  return x + information->ldlt().solve(J.transpose() * e + WtW * d);
}

GaussianState KernelSolve(const Problem& p, int passes) {
  GaussianState state = MakePrior(p.blocks, p.prior_mean, PriorScale{1, 1, 1});
  state.prior_variance = p.prior_sigma.cwiseAbs2();
  state.covariance = state.prior_variance.asDiagonal();
  SequenceOptions options;
  options.gauss_newton_from_start = true;
  options.max_passes = passes;
  FuseSequence(p.factors, &state, options);
  return state;
}

TEST_CASE(
    "stabilised Gauss-Newton: Lowe's (JᵀJ + WᵀW) δ = Jᵀe + WᵀW d is the kernel's iterated "
    "update with the prediction as prior, pass by pass, at convergence and in the covariance",
    "[estimator][tracking]") {
  for (unsigned seed : {1u, 2u, 3u}) {
    CAPTURE(seed);
    const Problem p = MakeProblem(seed);
    Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
    Eigen::Matrix<double, 6, 6> information;
    for (int pass = 1; pass <= 3; ++pass) {
      CAPTURE(pass);
      x = LoweStep(p, x, &information);
      const GaussianState state = KernelSolve(p, pass);
      const Eigen::VectorXd kernel = LocalCoordinates(p.blocks, p.prior_mean, state.mean);
      // Finite differences carry ~1e-9 of relative error into each step.
      CHECK((kernel - x).norm() <= 1e-7 * (1 + x.norm()));
    }
    // Converged: the same estimate, and the kernel's covariance is Lowe's (JᵀJ + WᵀW)⁻¹.
    for (int k = 0; k < 20; ++k) x = LoweStep(p, x, &information);
    const GaussianState state = KernelSolve(p, 20);
    const Eigen::VectorXd kernel = LocalCoordinates(p.blocks, p.prior_mean, state.mean);
    // (The kernel stops once a pass moves less than a tenth of a standard deviation; Gauss-Newton
    // converging quadratically, it is then within a thousandth.)
    CHECK((kernel - x).dot(information * (kernel - x)) <= 1e-6);
    // The kernel keeps its covariance in the chart centred on its estimate: Lowe's, in the
    // prior's chart, carried over by that change of chart (by finite differences).
    Eigen::Matrix<double, 6, 6> chart;
    auto recentred = [&](const Eigen::Matrix<double, 6, 1>& y) {
      Values at = p.prior_mean;
      Retract(p.blocks, y, &at);
      return LocalCoordinates(p.blocks, state.mean, at);
    };
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> h = Eigen::Matrix<double, 6, 1>::Zero();
      h[k] = 1e-6;
      chart.col(k) = (recentred(kernel + h) - recentred(kernel - h)) / 2e-6;
    }
    const Eigen::Matrix<double, 6, 6> lowe = chart * information.inverse() * chart.transpose();
    CHECK((state.covariance - lowe).norm() <= 1e-4 * lowe.norm());
    // And the prior mattered: without it the estimate would be the data's alone.
    CHECK(x.norm() > 1e-3);
  }
}

}  // namespace
}  // namespace cfuse
