// The fit of an estimate: the chi-square of whitened residuals and its p-value against a closed
// form, the directions the measurements leave free (exactly the null space of their Jacobian,
// whatever the model's extent), what constraints take away, what is left out, the counts of a
// state too large to name its free directions, and MovesAlong.
#include "cfuse/kernel/fit_analysis.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>

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

TEST_CASE("fit analysis: a state beyond the dense limit still has its ranks counted", "[kernel]") {
  // 520 points (1560 tangent dimensions > kMaxAnalysedDim): each but the last ten measured,
  // consecutive pairs 1..20 tied by an offset, the pair 1-2 twice. Counts: the constraints
  // take 3 x 20 (the repeat adds nothing); the ten unmeasured points are free (30), except
  // none of them is tied, so determined = model_dof − 30.
  const int points = 520;
  std::vector<Block> blocks;
  Values values;
  for (int i = 0; i < points; ++i) {
    blocks.push_back({BlockKind::kPoint, i, 3 * i, "p" + std::to_string(i)});
    values.points.push_back(Eigen::Vector3d(0.01 * i, 0, 0));
  }
  REQUIRE(3 * points > kMaxAnalysedDim);
  std::vector<Factor> factors;
  for (int i = 0; i + 10 < points; ++i) {
    factors.push_back(Measured(i, values.points[i], 1e-4 * Eigen::Matrix3d::Identity()));
  }
  const Eigen::Vector3d d(-0.01, 0, 0);
  for (int i = 1; i <= 20; ++i) {
    factors.push_back({std::make_shared<Offset>(d), {i, i + 1}, {}, "tie"});
  }
  factors.push_back({std::make_shared<Offset>(d), {1, 2}, {}, "tie again"});
  const FitAnalysis a = AnalyseFit(factors, blocks, values, 5.0);
  CHECK(a.analysed);
  CHECK(a.state_dim == 3 * points);
  CHECK(a.model_dof == 3 * points - 60);
  CHECK(a.determined == a.model_dof - 30);
  CHECK(a.fit.residuals == 3 * (points - 10));
  CHECK(a.fit.dof == a.fit.residuals - a.determined);
  CHECK(a.free_directions.size() == 0);  // not named beyond the dense limit
}

// The counts by the definition: rank C and rank M N (N a basis of C's null space) by dense
// SVDs of the scaled rows, the constraints' normalised, the measurements' whitened.
std::pair<int, int> DenseCounts(const std::vector<Factor>& factors,
                                const std::vector<Block>& blocks, const Values& values,
                                double extent) {
  int n = 0;
  for (const Block& b : blocks) n = std::max(n, b.tangent_offset + TangentDim(b.kind));
  std::vector<Eigen::RowVectorXd> c_rows, m_rows;
  for (const Factor& f : factors) {
    Eigen::VectorXd r;
    Eigen::MatrixXd j;
    EvaluateResidual(*f.residual, blocks, f.blocks, values, &r, &j);
    Eigen::MatrixXd full = Eigen::MatrixXd::Zero(r.size(), n);
    int column = 0;
    for (int block : f.blocks) {
      const Block& b = blocks[block];
      const int dim = TangentDim(b.kind);
      for (int k = 0; k < dim; ++k) {
        const bool position = b.kind == BlockKind::kPoint || (b.kind == BlockKind::kPose && k >= 3);
        full.col(b.tangent_offset + k) += j.col(column + k) * (position ? extent : 1.0);
      }
      column += dim;
    }
    if (f.is_constraint()) {
      for (int i = 0; i < full.rows(); ++i) c_rows.push_back(full.row(i).normalized());
    } else {
      const Eigen::MatrixXd w = Eigen::LLT<Eigen::MatrixXd>(f.noise).matrixL().solve(full);
      for (int i = 0; i < w.rows(); ++i) m_rows.push_back(w.row(i));
    }
  }
  const auto stack = [n](const std::vector<Eigen::RowVectorXd>& rows) {
    Eigen::MatrixXd m(static_cast<int>(rows.size()), n);
    for (size_t i = 0; i < rows.size(); ++i) m.row(static_cast<int>(i)) = rows[i];
    return m;
  };
  Eigen::MatrixXd null_space = Eigen::MatrixXd::Identity(n, n);
  if (!c_rows.empty()) {
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(stack(c_rows), Eigen::ComputeFullV);
    const int rank =
        static_cast<int>((svd.singularValues().array() > 1e-9 * svd.singularValues()[0]).count());
    null_space = svd.matrixV().rightCols(n - rank);
  }
  const Eigen::MatrixXd projected = stack(m_rows) * null_space;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(projected);
  const int determined =
      static_cast<int>((svd.singularValues().array() > 1e-6 * svd.singularValues()[0]).count());
  return {static_cast<int>(null_space.cols()), determined};
}

// r = pose ⊙ q − point: a pose block's feature point measured against a point block.
class PointOnPose : public AutoDiffResidual<PointOnPose> {
 public:
  explicit PointOnPose(const Eigen::Vector3d& q)
      : AutoDiffResidual(3, {BlockKind::kPose, BlockKind::kPoint}), q_(q) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> p = ModelPointInWorld(x[0], true, q_);
    for (int i = 0; i < 3; ++i) r[i] = p[i] - x[1].t[i];
  }
  std::string Describe(std::span<const std::string>) const override { return "on pose"; }

 private:
  Eigen::Vector3d q_;
};

TEST_CASE("fit analysis: the sparse counts agree with the dense decompositions", "[kernel]") {
  // Random models of 12 poses and 12 points (96 dimensions, past the dense shortcut): points
  // on poses as constraints (some twice), measurements of some points and of some poses' feature
  // points (of all in a third of the trials), and in half the trials measurements over two
  // blocks (the stacked path).
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> pick(0, 11);
  int with_free = 0, without = 0;
  for (int trial = 0; trial < 24; ++trial) {
    INFO("trial " << trial);
    std::vector<Block> blocks;
    Values values;
    for (int i = 0; i < 12; ++i) {
      blocks.push_back({BlockKind::kPose, i, 6 * i, "pose" + std::to_string(i)});
      values.poses.push_back(
          Rigid3d(Eigen::Quaterniond(1 + u(rng), u(rng), u(rng), u(rng)).normalized(),
                  Eigen::Vector3d(u(rng), u(rng), u(rng))));
    }
    for (int i = 0; i < 12; ++i) {
      blocks.push_back({BlockKind::kPoint, i, 72 + 3 * i, "point" + std::to_string(i)});
      values.points.push_back(Eigen::Vector3d(u(rng), u(rng), u(rng)));
    }
    std::vector<Factor> factors;
    const Eigen::Matrix3d noise = 1e-4 * Eigen::Matrix3d::Identity();
    for (int k = 0; k < 10 + trial % 6; ++k) {
      const int pose = pick(rng), point = pick(rng);
      const Eigen::Vector3d q(u(rng), u(rng), u(rng));
      factors.push_back({std::make_shared<PointOnPose>(q), {pose, 12 + point}, {}, "tie"});
      if (k % 4 == 0) factors.push_back(factors.back());  // a repeated constraint
    }
    for (int k = 0; k < 6 + trial % 5; ++k) {
      factors.push_back(Measured(12 + pick(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)), noise));
      const Eigen::Vector3d q(u(rng), u(rng), u(rng));
      factors.push_back({std::make_shared<Point3Residual>(q, Eigen::Vector3d(u(rng), 0, 0)),
                         {pick(rng)},
                         noise,
                         "z"});
    }
    if (trial % 3 == 0) {  // everything measured: nothing left free
      for (int i = 0; i < 12; ++i) {
        factors.push_back(Measured(12 + i, values.points[i], noise));
        for (const Eigen::Vector3d& q :
             {Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(0, 0.1, 0), Eigen::Vector3d(0, 0, 0.1)}) {
          factors.push_back(
              {std::make_shared<Point3Residual>(q, values.poses[i] * q), {i}, noise, "z"});
        }
      }
    }
    if (trial % 2) {
      factors.push_back({std::make_shared<Offset>(Eigen::Vector3d(0.1, 0, 0)),
                         {12 + pick(rng), 12 + pick(rng)},
                         noise,
                         "between"});
    }
    const FitAnalysis a = AnalyseFit(factors, blocks, values, 2.0);
    const auto [model_dof, determined] = DenseCounts(factors, blocks, values, 2.0);
    CHECK(a.model_dof == model_dof);
    CHECK(a.determined == determined);
    CHECK(a.free_directions.cols() == model_dof - determined);
    (determined < model_dof ? with_free : without)++;
  }
  CHECK(with_free > 0);
  CHECK(without > 0);
}

// FreeDirections on an information matrix whose eigenvalues are set: the directions left free
// are those at or below 1e-12 of the largest, found whether the quick bound decides (well
// conditioned) or the eigenvalues do (one eigenvalue just above or just below the tolerance),
// with and without a constraint row.
TEST_CASE("fit analysis: FreeDirections counts the eigenvalues at the tolerance", "[kernel]") {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  Eigen::MatrixXd random(6, 6);
  for (int i = 0; i < random.size(); ++i) random.data()[i] = n(rng);
  const Eigen::MatrixXd Q = Eigen::HouseholderQR<Eigen::MatrixXd>(random).householderQ();
  const auto information = [&](double smallest) {
    Eigen::VectorXd lambda(6);
    lambda << 1, 0.5, 0.3, 2, 0.8, smallest;
    return Eigen::MatrixXd(Q * lambda.asDiagonal() * Q.transpose());
  };
  const Eigen::MatrixXd none(0, 6);
  for (const auto& [smallest, free] :
       std::vector<std::pair<double, int>>{{0.1, 0}, {1e-9, 0}, {1e-11, 0}, {1e-13, 1}, {0, 1}}) {
    INFO("smallest eigenvalue " << smallest);
    int model_dof = -1, determined = -1;
    const Eigen::MatrixXd directions =
        FreeDirections(none, information(smallest), &model_dof, &determined);
    CHECK(model_dof == 6);
    CHECK(determined == 6 - free);
    REQUIRE(directions.cols() == free);
    if (free == 1) CHECK(std::abs(directions.col(0).dot(Q.col(5))) == Approx(1).epsilon(1e-6));
    // A constraint row along the free direction takes it from the model: nothing left free.
    const Eigen::MatrixXd along = Q.col(5).transpose();
    CHECK(FreeDirections(along, information(smallest), &model_dof, &determined).cols() == 0);
    CHECK(model_dof == 5);
    CHECK(determined == 5);
    // One across it leaves it free.
    const Eigen::MatrixXd across = Q.col(0).transpose();
    CHECK(FreeDirections(across, information(smallest), &model_dof, &determined).cols() == free);
    CHECK(determined == 5 - free);
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
