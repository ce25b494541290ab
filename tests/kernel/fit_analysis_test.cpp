// The fit of an estimate: the chi-square of whitened residuals and its p-value against a closed
// form, the directions the measurements leave free (exactly the null space of their Jacobian,
// whatever the model's extent), what constraints take away, what is left out, and MovesAlong.
#include "cfuse/kernel/fit_analysis.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/point3.h"

namespace cfuse {
namespace {

// r = a - b - d, two point blocks.
class Offset : public AutoDiffResidual<Offset> {
 public:
  explicit Offset(const Eigen::Vector3d& d)
      : AutoDiffResidual(3, {BlockKind::kPoint, BlockKind::kPoint}), d_(d) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    for (int i = 0; i < 3; ++i) r[i] = x[0].t[i] - x[1].t[i] - T(d_[i]);
  }
  std::string Describe(std::span<const std::string>) const override { return "offset"; }

 private:
  Eigen::Vector3d d_;
};

struct Points {
  std::vector<Block> blocks = {{BlockKind::kPoint, 0, 0, "a"}, {BlockKind::kPoint, 1, 3, "b"}};
  Values values;
  Points() { values.points = {Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 1, 1)}; }
};

Factor Measured(int block, const Eigen::Vector3d& z, const Eigen::Matrix3d& noise) {
  return {std::make_shared<Point3Residual>(z), {block}, noise, "z"};
}

TEST_CASE("fit analysis: chi-square, its degrees of freedom and p-value", "[kernel]") {
  const Points s;
  const Eigen::Matrix3d noise = 1e-4 * Eigen::Matrix3d::Identity();  // σ = 1 cm
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Factor> factors = {
      Measured(0, {0.01, 0, 0}, noise), Measured(0, {0, -0.02, 0.01}, noise),
      Measured(0, {nan, 0, 0}, noise),                   // not finite: left out
      Measured(0, {1, 1, 1}, Eigen::Matrix3d::Zero())};  // no valid noise: left out
  const FitAnalysis a = AnalyseFit(factors, s.blocks, s.values, 0.5);
  CHECK(a.analysed);
  CHECK(a.state_dim == 6);
  CHECK(a.model_dof == 6);
  CHECK(a.determined == 3);
  CHECK(a.fit.residuals == 6);
  CHECK(a.fit.dof == 3);
  CHECK(a.fit.chi2 == Approx(1 + 4 + 1));
  // P(χ²₃ > x) = erfc(√(x/2)) + √(2x/π) e^(-x/2).
  CHECK(a.fit.p_value == Approx(std::erfc(std::sqrt(3.0)) + std::sqrt(12 / M_PI) * std::exp(-3.0)));
  // b is not measured: its three coordinates are free.
  REQUIRE(a.free_directions.rows() == 6);
  REQUIRE(a.free_directions.cols() == 3);
  CHECK(a.free_directions.topRows(3).norm() < 1e-12);
  CHECK((a.free_directions.bottomRows(3).transpose() * a.free_directions.bottomRows(3) -
         Eigen::Matrix3d::Identity())
            .norm() < 1e-12);

  // Without ranks every direction the constraints allow counts as determined.
  const FitAnalysis cheap = AnalyseFit(factors, s.blocks, s.values, 0.5, false);
  CHECK_FALSE(cheap.analysed);
  CHECK(cheap.model_dof == 6);
  CHECK(cheap.determined == 6);
  CHECK(cheap.fit.dof == 0);
  CHECK(cheap.fit.p_value == 1);
  CHECK(cheap.fit.chi2 == a.fit.chi2);
  CHECK(cheap.free_directions.size() == 0);
}

TEST_CASE("fit analysis: constraints take their rows from the model's freedom", "[kernel]") {
  const Points s;
  const std::vector<Factor> factors = {
      Measured(0, {0.01, 0, 0}, 1e-4 * Eigen::Matrix3d::Identity()),
      {std::make_shared<Offset>(Eigen::Vector3d(-1, -1, -1)), {0, 1}, {}, "a - b"},
      {std::make_shared<Offset>(Eigen::Vector3d(-1, -1, -1)), {0, 1}, {}, "again"}};
  for (const bool ranks : {true, false}) {
    const FitAnalysis a = AnalyseFit(factors, s.blocks, s.values, 0.5, ranks);
    INFO("ranks " << ranks);
    // The repeated constraint is one rank, not two, when ranks are taken.
    CHECK(a.model_dof == (ranks ? 3 : 0));
    CHECK(a.determined == (ranks ? 3 : 0));
    CHECK(a.fit.residuals == 3);
    CHECK(a.fit.dof == (ranks ? 0 : 3));
    CHECK(a.free_directions.size() == 0);
  }
}

TEST_CASE("fit analysis: a pose seen at one point turns freely about it, in any units",
          "[kernel]") {
  const std::vector<Block> blocks = {{BlockKind::kPose, 0, 0, "box"}};
  Values values;
  values.poses = {Rigid3d(Eigen::Quaterniond(0.8, 0.1, 0.5, -0.3).normalized(),
                          Eigen::Vector3d(0.2, 0.1, 1.4))};
  const Eigen::Vector3d seen(0.2, 0, 0), unseen(0, 0.3, 0.1);
  const std::vector<Factor> factors = {
      {std::make_shared<Point3Residual>(seen, Eigen::Vector3d(0.3, 0.2, 1.5)),
       {0},
       1e-6 * Eigen::Matrix3d::Identity(),
       "z"}};
  // The world position of a feature point q moves by [-R [q]x, I] per tangent coordinate.
  const Eigen::Matrix3d R = values.poses[0].RotationMatrix();
  auto gradient = [&](const Eigen::Vector3d& q) {
    Eigen::Matrix<double, 3, 6> g;
    g << -R * Hat<double>(q), Eigen::Matrix3d::Identity();
    return g;
  };
  for (const double extent : {0.5, 500.0}) {
    const FitAnalysis a = AnalyseFit(factors, blocks, values, extent);
    INFO("extent " << extent);
    CHECK(a.model_dof == 6);
    CHECK(a.determined == 3);
    REQUIRE(a.free_directions.cols() == 3);
    // Exactly the directions that keep the seen point in place.
    CHECK((gradient(seen) * a.free_directions).norm() < 1e-9);
    for (int i = 0; i < 3; ++i) CHECK_FALSE(MovesAlong(gradient(seen).row(i), a.free_directions));
    bool moves = false;
    for (int i = 0; i < 3; ++i) {
      moves = moves || MovesAlong(gradient(unseen).row(i), a.free_directions);
    }
    CHECK(moves);
  }
}

TEST_CASE("fit analysis: MovesAlong and its tolerance", "[kernel]") {
  const Eigen::RowVectorXd g = Eigen::RowVector3d(1, 0, 0);
  const Eigen::MatrixXd nearly_normal = Eigen::Vector3d(1e-7, 1, 0).normalized();
  CHECK_FALSE(MovesAlong(g, Eigen::MatrixXd(3, 0)));
  CHECK_FALSE(MovesAlong(Eigen::RowVectorXd::Zero(3), Eigen::MatrixXd::Identity(3, 3)));
  CHECK(MovesAlong(g, Eigen::MatrixXd::Identity(3, 3)));
  CHECK_FALSE(MovesAlong(g, nearly_normal));
  CHECK(MovesAlong(g, nearly_normal, 1e-8));
  CHECK_FALSE(MovesAlong(1e6 * g, nearly_normal));  // relative to |gradient|
}

}  // namespace
}  // namespace cfuse
