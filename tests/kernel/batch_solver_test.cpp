// The batch reference solver against independent references: the closed-form Gaussian
// posterior of a linear measurement; the KKT system of a linear equality constraint solved
// densely, with the constrained covariance by conditioning, unmoved by a repeated row; a
// contradiction's residual; and on a pose measured at three points, the objective stationary at
// the solution (central differences) and the covariance from finite-difference Jacobians moved
// to the solution's chart.
#include "cfuse/kernel/batch_solver.h"

#include <Eigen/LU>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <string>

#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/point3.h"

namespace cfuse {
namespace {

// r = Σ_k A_k x_k - c over point blocks.
class Linear : public AutoDiffResidual<Linear> {
 public:
  Linear(std::vector<Eigen::MatrixXd> A, Eigen::VectorXd c)
      : AutoDiffResidual(static_cast<int>(c.size()),
                         std::vector<BlockKind>(A.size(), BlockKind::kPoint)),
        A_(std::move(A)),
        c_(std::move(c)) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    for (int i = 0; i < c_.size(); ++i) {
      r[i] = T(-c_[i]);
      for (size_t k = 0; k < A_.size(); ++k) {
        for (int j = 0; j < 3; ++j) r[i] += T(A_[k](i, j)) * x[k].t[j];
      }
    }
  }
  bool is_linear() const override { return true; }
  std::string Describe(std::span<const std::string>) const override { return "linear"; }

 private:
  std::vector<Eigen::MatrixXd> A_;
  Eigen::VectorXd c_;
};

Eigen::MatrixXd Spd(int n, unsigned seed, double scale) {
  std::srand(seed);
  const Eigen::MatrixXd A = Eigen::MatrixXd::Random(n, n);
  return scale * (A * A.transpose() / n + 0.5 * Eigen::MatrixXd::Identity(n, n));
}

GaussianState PointsPrior(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  GaussianState state;
  const int n = static_cast<int>(mean.size()) / 3;
  for (int k = 0; k < n; ++k) {
    state.blocks.push_back({BlockKind::kPoint, k, 3 * k, "p" + std::to_string(k)});
    state.mean.points.push_back(mean.segment<3>(3 * k));
  }
  state.covariance = covariance;
  state.groups = CorrelationGroups(n);
  return state;
}

Eigen::VectorXd Stacked(const Values& v) {
  Eigen::VectorXd x(3 * v.points.size());
  for (size_t k = 0; k < v.points.size(); ++k) x.segment<3>(3 * k) = v.points[k];
  return x;
}

TEST_CASE("batch solver: a linear measurement gives the Gaussian posterior", "[kernel]") {
  const Eigen::Vector3d x0(1, 2, 3), z(1.5, 1.0, 3.2);
  const Eigen::MatrixXd P0 = Spd(3, 1, 0.04), R = Spd(3, 2, 0.01);
  GaussianState state = PointsPrior(x0, P0);
  const std::vector<Factor> factors = {{std::make_shared<Point3Residual>(z), {0}, R, "z"}};
  const BatchSummary summary = SolveBatch(factors, &state);
  CHECK(summary.converged);
  CHECK(summary.iterations <= 3);
  CHECK(summary.max_constraint_residual == 0);
  const Eigen::Matrix3d P = (P0.inverse() + R.inverse()).inverse();
  const Eigen::Vector3d x = P * (P0.inverse() * x0 + R.inverse() * z);
  CHECK((state.mean.points[0] - x).norm() < 1e-12);
  CHECK((state.covariance - P).norm() < 1e-12 * P.norm());
}

TEST_CASE("batch solver: a linear equality constraint solves the KKT system", "[kernel]") {
  // Points a and b, a measured, a - b = d held, and the x row of it written again.
  Eigen::VectorXd x0(6);
  x0 << 0.1, 0.2, 0.3, 1.0, 1.1, 0.9;
  const Eigen::MatrixXd P0 = Spd(6, 3, 0.05), R = Spd(3, 4, 0.001);
  const Eigen::Vector3d z(0.15, 0.1, 0.35), d(-1, -1, -0.5);
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const std::vector<Factor> factors = {
      {std::make_shared<Point3Residual>(z), {0}, R, "z"},
      {std::make_shared<Linear>(std::vector<Eigen::MatrixXd>{I, -I}, d), {0, 1}, {}, "a - b"},
      {std::make_shared<Linear>(std::vector<Eigen::MatrixXd>{I.topRows(1), -I.topRows(1)},
                                d.head(1)),
       {0, 1},
       {},
       "again"}};
  // min ½ (x - x0)ᵀ P0⁻¹ (x - x0) + ½ (H x - z)ᵀ R⁻¹ (H x - z) subject to A x = d.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3, 6), A(3, 6);
  H.leftCols(3) = I;
  A << I, -I;
  const Eigen::MatrixXd Lambda = P0.inverse() + H.transpose() * R.inverse() * H;
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(9, 9);
  kkt.topLeftCorner(6, 6) = Lambda;
  kkt.topRightCorner(6, 3) = A.transpose();
  kkt.bottomLeftCorner(3, 6) = A;
  Eigen::VectorXd rhs(9);
  rhs << P0.inverse() * x0 + H.transpose() * R.inverse() * z, d;
  const Eigen::VectorXd x = kkt.fullPivLu().solve(rhs).head(6);
  const Eigen::MatrixXd S = Lambda.inverse();
  const Eigen::MatrixXd P = S - S * A.transpose() * (A * S * A.transpose()).inverse() * A * S;

  for (const bool from_elsewhere : {false, true}) {
    GaussianState state = PointsPrior(x0, P0);
    Values start = state.mean;
    start.points = {Eigen::Vector3d(5, -5, 2), Eigen::Vector3d(-3, 0, 1)};
    const BatchSummary summary = SolveBatch(factors, &state, {}, from_elsewhere ? &start : nullptr);
    INFO("from elsewhere " << from_elsewhere);
    CHECK(summary.converged);
    CHECK(summary.max_constraint_residual < 1e-12);
    CHECK((Stacked(state.mean) - x).norm() < 1e-10);
    CHECK((state.covariance - P).norm() < 1e-10 * P.norm());
    CHECK((A * state.covariance).norm() < 1e-10);  // no variance off the constraint surface
  }
}

TEST_CASE("batch solver: contradictory constraints leave their residual, reported", "[kernel]") {
  GaussianState state = PointsPrior(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  const Eigen::MatrixXd x = Eigen::RowVector3d(1, 0, 0);
  const std::vector<Factor> factors = {
      {std::make_shared<Linear>(std::vector<Eigen::MatrixXd>{x}, Eigen::VectorXd::Zero(1)),
       {0},
       {},
       "x = 0"},
      {std::make_shared<Linear>(std::vector<Eigen::MatrixXd>{x}, Eigen::VectorXd::Ones(1)),
       {0},
       {},
       "x = 1"}};
  const BatchSummary summary = SolveBatch(factors, &state);
  // The least-squares compromise of the two rows: x = 0.5, each off by 0.5.
  CHECK(state.mean.points[0].x() == Approx(0.5));
  CHECK(summary.max_constraint_residual == Approx(0.5));
  CHECK(state.covariance(0, 0) == Approx(0).margin(1e-12));
  CHECK(state.covariance(1, 1) == Approx(1));
}

// A pose seen at three of its points, with a prior off by a few degrees and centimetres.
struct PoseProblem {
  std::vector<Block> blocks = {{BlockKind::kPose, 0, 0, "box"}};
  Values prior;
  Eigen::Matrix<double, 6, 6> P0 = Eigen::Matrix<double, 6, 6>::Zero();
  std::vector<Factor> factors;
  double sigma = 0.002;

  PoseProblem() {
    const Rigid3d truth(Eigen::Quaterniond(0.9, 0.2, -0.3, 0.1).normalized(),
                        Eigen::Vector3d(0.1, -0.2, 1.5));
    const Eigen::Vector3d local[] = {{0.1, 0, 0}, {0, 0.15, 0}, {0, 0, 0.2}};
    const Eigen::Vector3d noise[] = {{0.001, -0.002, 0}, {0, 0.001, 0.003}, {-0.002, 0, 0.001}};
    for (int k = 0; k < 3; ++k) {
      factors.push_back({std::make_shared<Point3Residual>(local[k], truth * local[k] + noise[k]),
                         {0},
                         sigma * sigma * Eigen::Matrix3d::Identity(),
                         "p"});
    }
    prior.poses = {Rigid3d(truth.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(
                                                0.08, Eigen::Vector3d(1, 2, -1).normalized())),
                           truth.translation + Eigen::Vector3d(0.03, -0.02, 0.04))};
    P0.diagonal() << 0.01, 0.01, 0.01, 0.0025, 0.0025, 0.0025;
  }

  // The measurements' residuals, stacked, at prior ⊞ x.
  Eigen::VectorXd Residuals(const Eigen::Matrix<double, 6, 1>& x) const {
    Values at = prior;
    Retract(blocks, x, &at);
    Eigen::VectorXd out(9), r;
    for (int k = 0; k < 3; ++k) {
      EvaluateResidual(*factors[k].residual, blocks, factors[k].blocks, at, &r, nullptr);
      out.segment<3>(3 * k) = r;
    }
    return out;
  }
  double Objective(const Eigen::Matrix<double, 6, 1>& x) const {
    return 0.5 * x.dot(P0.inverse() * x) + 0.5 * Residuals(x).squaredNorm() / (sigma * sigma);
  }
};

TEST_CASE("batch solver: a nonlinear pose, stationary, its covariance in its own chart",
          "[kernel]") {
  const PoseProblem p;
  GaussianState state;
  state.blocks = p.blocks;
  state.mean = p.prior;
  state.covariance = p.P0;
  const BatchSummary summary = SolveBatch(p.factors, &state);
  REQUIRE(summary.converged);
  const Eigen::Matrix<double, 6, 1> x = LocalCoordinates(p.blocks, p.prior, state.mean);
  CHECK(x.head<3>().norm() > 0.05);  // it moved

  // The gradient of the objective in the prior's chart vanishes at the solution.
  const double h = 1e-6;
  Eigen::MatrixXd J(9, 6);
  for (int i = 0; i < 6; ++i) {
    Eigen::Matrix<double, 6, 1> e = Eigen::Matrix<double, 6, 1>::Zero();
    e[i] = h;
    const double gradient = (p.Objective(x + e) - p.Objective(x - e)) / (2 * h);
    INFO("coordinate " << i);
    CHECK(std::abs(gradient) < 1e-3);  // 1e-6 off the optimum would show as about 2e-3
    J.col(i) = (p.Residuals(x + e) - p.Residuals(x - e)) / (2 * h);
  }
  // (P0⁻¹ + Jᵀ R⁻¹ J)⁻¹ in the prior's chart, moved to the solution's by Jr(δθ) on the rotation.
  const Eigen::MatrixXd P = (p.P0.inverse() + J.transpose() * J / (p.sigma * p.sigma)).inverse();
  Eigen::MatrixXd G = Eigen::MatrixXd::Identity(6, 6);
  G.topLeftCorner(3, 3) = RightJacobianSO3(x.head<3>());
  CHECK((state.covariance - G * P * G.transpose()).norm() < 1e-6 * P.norm());

  // One iteration is not enough from there.
  GaussianState once;
  once.blocks = p.blocks;
  once.mean = p.prior;
  once.covariance = p.P0;
  BatchOptions options;
  options.max_iterations = 1;
  const BatchSummary short_summary = SolveBatch(p.factors, &once, options);
  CHECK_FALSE(short_summary.converged);
  CHECK(short_summary.iterations == 1);
}

}  // namespace
}  // namespace cfuse
