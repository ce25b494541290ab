// The estimator on the kernel alone (cfuse/kernel/estimator.h): a measurement update is the
// Kalman update in closed form, a constraint is a measurement of zero variance (met exactly,
// then redundant, or contradicted), and an update with no value says at which row. Whole
// models (with the DSL) are in tests/fusion/estimator_test.cpp.
#include "cfuse/kernel/estimator.h"

#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>
#include <memory>
#include <random>

#include "cfuse/kernel/measurements/image_point.h"
#include "cfuse/kernel/measurements/point3.h"
#include "cfuse/kernel/measurements/stacked.h"
#include "test_util.h"

namespace cfuse {
namespace {

const std::vector<Block> kOnePoint = {{BlockKind::kPoint, 0, 0, "p"}};

GaussianState PointPrior(const Eigen::Vector3d& mean, double sigma) {
  Values v;
  v.points = {mean};
  PriorScale scale;
  scale.position = sigma;
  return MakePrior(kOnePoint, v, scale);
}

Factor PointFactor(const Eigen::Vector3d& z, const Eigen::Matrix3d& noise, const char* name) {
  return {std::make_shared<Point3Residual>(z), {0}, noise, name};
}

TEST_CASE("estimator: a point measurement is the Kalman update in closed form", "[kernel]") {
  const Eigen::Vector3d x0(0.1, -0.2, 0.3), z(0.15, -0.1, 0.28);
  GaussianState state = PointPrior(x0, 0.5);
  const Eigen::Matrix3d P0 = state.covariance;
  Eigen::Matrix3d R;
  R << 0.04, 0.01, 0, 0.01, 0.09, -0.02, 0, -0.02, 0.01;
  const FusionSummary s = Fuse(PointFactor(z, R, "z"), &state);
  CHECK(s.status == FusionSummary::Status::kFused);
  CHECK(s.rows_fused == 3);
  const Eigen::Matrix3d K = P0 * (P0 + R).inverse();
  CHECK((state.mean.points[0] - (x0 + K * (z - x0))).norm() < 1e-12);
  CHECK((state.covariance - (P0 - K * P0)).norm() < 1e-12);
  // The normalised innovation, (z - x0)ᵀ (P0 + R)⁻¹ (z - x0).
  CHECK(s.innovation_nis == Approx((z - x0).dot((P0 + R).inverse() * (z - x0))).epsilon(1e-10));
}

TEST_CASE("estimator: a constraint is met exactly, then redundant, then contradicted",
          "[kernel]") {
  GaussianState state = PointPrior(Eigen::Vector3d(1, 2, 3), 0.5);
  const Eigen::Vector3d held(1.1, 1.9, 3.05);
  const Factor constraint{std::make_shared<Point3Residual>(held), {0}, {}, "held"};
  REQUIRE(constraint.is_constraint());
  CHECK(Fuse(constraint, &state).status == FusionSummary::Status::kFused);
  CHECK((state.mean.points[0] - held).norm() < 1e-12);
  CHECK(state.covariance.norm() < 1e-12);  // known to zero variance
  // Met again: nothing to fuse.
  const GaussianState before = state;
  CHECK(Fuse(constraint, &state).status == FusionSummary::Status::kRedundant);
  CHECK(state.mean.points[0] == before.mean.points[0]);
  // Another place for a point known exactly: a contradiction, the state unchanged.
  const Factor other{std::make_shared<Point3Residual>(Eigen::Vector3d(1.2, 1.9, 3.05)),
                     {0},
                     {},
                     "elsewhere"};
  const FusionSummary s = Fuse(other, &state);
  CHECK(s.status == FusionSummary::Status::kContradiction);
  CHECK(s.contradiction > 0);
  CHECK(state.mean.points[0] == before.mean.points[0]);
  CHECK(state.covariance == before.covariance);
}

// One row, the filter's own path for scalar constraints: a point's distance from the origin.
class RadiusResidual : public AutoDiffResidual<RadiusResidual> {
 public:
  explicit RadiusResidual(double radius)
      : AutoDiffResidual(1, {BlockKind::kPoint}), radius_(radius) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    r[0] = x[0].t.norm() - T(radius_);
  }
  std::string Describe(std::span<const std::string> names) const override {
    return "|" + names[0] + "| == radius";
  }

 private:
  double radius_;
};

TEST_CASE("estimator: a one-row constraint is met exactly, then redundant, then contradicted",
          "[kernel]") {
  GaussianState state = PointPrior(Eigen::Vector3d(1, 2, 2), 0.5);
  const Factor constraint{std::make_shared<RadiusResidual>(2.5), {0}, {}, "radius"};
  const FusionSummary fused = Fuse(constraint, &state);
  CHECK(fused.status == FusionSummary::Status::kFused);
  CHECK(fused.rows_fused == 1);
  CHECK(std::abs(state.mean.points[0].norm() - 2.5) < 1e-10);
  // Known to zero variance along the radius only: the sphere's two tangent directions keep theirs.
  const Eigen::Vector3d radial = state.mean.points[0].normalized();
  CHECK(radial.dot(state.covariance * radial) < 1e-12);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(state.covariance);
  CHECK(eigen.eigenvalues()(1) == Approx(0.25).epsilon(0.05));
  CHECK(eigen.eigenvalues()(2) == Approx(0.25).epsilon(0.05));
  const GaussianState before = state;
  CHECK(Fuse(constraint, &state).status == FusionSummary::Status::kRedundant);
  CHECK(state.mean.points[0] == before.mean.points[0]);
  // Another radius for a radius known exactly: a contradiction, the state unchanged. With the
  // radial direction still uncertain it would be fused instead.
  const Factor other{std::make_shared<RadiusResidual>(2.6), {0}, {}, "other radius"};
  const FusionSummary s = Fuse(other, &state);
  CHECK(s.status == FusionSummary::Status::kContradiction);
  CHECK(s.contradiction > 1e-3);
  CHECK(state.mean.points[0] == before.mean.points[0]);
  CHECK(state.covariance == before.covariance);
}

TEST_CASE("estimator: an update with no value names its first row, the state unchanged",
          "[kernel]") {
  // A point measured in 3D and in an image, stacked: behind the camera the image's rows (3 and
  // 4) have no value.
  const Camera camera = testing::Pinhole();
  for (const double z : {-0.5, 0.5}) {
    INFO("z " << z);
    GaussianState state = PointPrior(Eigen::Vector3d(0.01, 0, z), 1.0);
    const GaussianState before = state;
    const std::vector<std::shared_ptr<const ResidualFunction>> parts = {
        std::make_shared<Point3Residual>(Eigen::Vector3d(0.01, 0, z)),
        std::make_shared<ImagePointResidual>(camera, Eigen::Vector2d(336, 240))};
    const Factor f{std::make_shared<StackedResidual>(parts), {0},
                   Eigen::MatrixXd::Identity(5, 5), "stacked"};
    const FusionSummary s = Fuse(f, &state);
    if (z < 0) {
      CHECK(s.status == FusionSummary::Status::kInvalid);
      CHECK(s.invalid_row == 3);
      CHECK(state.mean.points[0] == before.mean.points[0]);
      CHECK(state.covariance == before.covariance);
    } else {
      CHECK(s.changed_state());
      CHECK(s.invalid_row == -1);
    }
  }
}

// r = A [p; q] - z on two points: a linear measurement of any number of rows.
class TwoPointLinear : public AutoDiffResidual<TwoPointLinear> {
 public:
  TwoPointLinear(Eigen::MatrixXd A, Eigen::VectorXd z)
      : AutoDiffResidual(static_cast<int>(A.rows()), {BlockKind::kPoint, BlockKind::kPoint}),
        A_(std::move(A)),
        z_(std::move(z)) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    for (int i = 0; i < A_.rows(); ++i) {
      r[i] = T(-z_(i));
      for (int j = 0; j < 3; ++j) r[i] += A_(i, j) * x[0].t[j] + A_(i, 3 + j) * x[1].t[j];
    }
  }
  bool is_linear() const override { return true; }
  std::string Describe(std::span<const std::string> names) const override {
    return "A [" + names[0] + "; " + names[1] + "]";
  }

 private:
  Eigen::MatrixXd A_;
  Eigen::VectorXd z_;
};

// Three points whose prior is correlated (one group): `covariance` is 9 x 9.
GaussianState CorrelatedPrior(const Eigen::MatrixXd& covariance) {
  const std::vector<Block> blocks = {{BlockKind::kPoint, 0, 0, "p"},
                                     {BlockKind::kPoint, 1, 3, "q"},
                                     {BlockKind::kPoint, 2, 6, "w"}};
  Values v;
  v.points = {Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(-0.4, 0.5, 0.1),
              Eigen::Vector3d(0.7, -0.2, 0.9)};
  GaussianState state = MakePrior(blocks, v, PriorScale{});
  state.covariance = covariance;
  state.groups.MergeAll();
  return state;
}

Eigen::VectorXd Stacked(const Values& v) {
  Eigen::VectorXd x(9);
  for (int b = 0; b < 3; ++b) x.segment<3>(3 * b) = v.points[b];
  return x;
}

// The two ways the filter whitens a measurement, fixed-size for three rows and general for
// the others, on two of three correlated points, each against the Kalman update in closed form
// over all three (the third point moves through its correlation only).
TEST_CASE("estimator: measurements of 1 to 5 rows on correlated points are the Kalman update",
          "[kernel]") {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0, 1);
  const auto random = [&](int rows, int cols) {
    Eigen::MatrixXd m(rows, cols);
    for (int j = 0; j < cols; ++j) {
      for (int i = 0; i < rows; ++i) m(i, j) = g(rng);
    }
    return m;
  };
  for (int m = 1; m <= 5; ++m) {
    INFO(m << " rows");
    const Eigen::MatrixXd L = random(9, 9);
    const Eigen::MatrixXd P0 = 0.01 * (L * L.transpose()) + 1e-3 * Eigen::MatrixXd::Identity(9, 9);
    GaussianState state = CorrelatedPrior(P0);
    const Eigen::VectorXd x0 = Stacked(state.mean);
    const Eigen::MatrixXd A = random(m, 6), E = random(m, m);
    const Eigen::MatrixXd R = 0.01 * (E * E.transpose()) + 1e-3 * Eigen::MatrixXd::Identity(m, m);
    const Eigen::VectorXd z = random(m, 1);
    const Factor f{std::make_shared<TwoPointLinear>(A, z), {0, 1}, R, "A x"};
    const FusionSummary s = Fuse(f, &state);
    CHECK(s.status == FusionSummary::Status::kFused);
    CHECK(s.rows_fused == m);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m, 9);
    H.leftCols(6) = A;
    const Eigen::MatrixXd S = H * P0 * H.transpose() + R;
    const Eigen::MatrixXd K = P0 * H.transpose() * S.inverse();
    const Eigen::VectorXd innovation = z - H * x0;
    CHECK((Stacked(state.mean) - (x0 + K * innovation)).norm() < 1e-12);
    CHECK((state.covariance - (P0 - K * S * K.transpose())).norm() < 1e-12);
    CHECK(s.innovation_nis == Approx(innovation.dot(S.inverse() * innovation)).epsilon(1e-10));
  }
}

// A curved constraint on one of three correlated points: the local iterations run on the
// point's own coordinates and the others follow through the gain of the last linearisation
// only. Against the iterated update written out over all three points.
TEST_CASE("estimator: a curved constraint moves correlated points by the iterated update",
          "[kernel]") {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0, 1);
  Eigen::MatrixXd L(9, 9);
  for (int j = 0; j < 9; ++j) {
    for (int i = 0; i < 9; ++i) L(i, j) = g(rng);
  }
  const Eigen::MatrixXd P0 = 0.01 * (L * L.transpose()) + 1e-3 * Eigen::MatrixXd::Identity(9, 9);
  GaussianState state = CorrelatedPrior(P0);
  const Eigen::VectorXd x0 = Stacked(state.mean);
  const double radius = 0.5;
  const Factor f{std::make_shared<RadiusResidual>(radius), {1}, {}, "|q| == 0.5"};
  const FusionSummary s = Fuse(f, &state);
  CHECK(s.status == FusionSummary::Status::kFused);
  CHECK(s.iterations >= 2);  // curved: more than one step
  // x_{i+1} = x0 + K_i (H_i (x_i - x0) - r(x_i)), K_i = P0 H_iᵀ (H_i P0 H_iᵀ)⁻¹, as many steps
  // as the filter took (it stops once the constraint is met, before the iterate's tangential
  // part has settled to the last digit).
  Eigen::VectorXd x = x0;
  Eigen::RowVectorXd H = Eigen::RowVectorXd::Zero(9);
  for (int i = 0; i < s.iterations; ++i) {
    const Eigen::Vector3d q = x.segment<3>(3);
    H.setZero();
    H.segment<3>(3) = q.normalized().transpose();
    const Eigen::VectorXd K = P0 * H.transpose() / (H * P0 * H.transpose())(0, 0);
    x = x0 + K * (H.dot(x - x0) - (q.norm() - radius));
  }
  CHECK(std::abs(state.mean.points[1].norm() - radius) < 1e-9);
  CHECK((Stacked(state.mean) - x).norm() < 1e-14);
  // The covariance from the linearisation at the answer.
  H.setZero();
  H.segment<3>(3) = x.segment<3>(3).normalized().transpose();
  const Eigen::VectorXd K = P0 * H.transpose() / (H * P0 * H.transpose())(0, 0);
  CHECK((state.covariance - (P0 - K * H * P0)).norm() < 1e-14);
}

}  // namespace
}  // namespace cfuse
