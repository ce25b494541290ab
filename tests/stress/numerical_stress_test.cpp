// Numerical stress (issue 8, "Reliability"), part 1: the covariance of constraint fusion stays
// symmetric, positive semidefinite and finite over 10^5 random updates through Fuse(), the
// update every estimator runs: zero-variance constraints, rank-deficient and near-singular
// Jacobians, tiny and huge variances, the same constraint fused again and again.
// Degenerate models and data, end to end: scenarios_test.cpp.
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <sstream>

#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/residual.h"

namespace cfuse {
namespace {

// r = A f(x) - z, where f stacks per slot: a point's position (3), two feature points
// R c_k + t of a pose (6, nonlinear in the rotation), a slack's λ (1). A sets the rank and
// conditioning of the Jacobian.
class MixedResidual : public AutoDiffResidual<MixedResidual> {
 public:
  MixedResidual(std::vector<BlockKind> kinds, Eigen::MatrixXd A, Eigen::VectorXd z)
      : AutoDiffResidual(static_cast<int>(A.rows()), kinds),
        kinds_(std::move(kinds)),
        A_(std::move(A)),
        z_(std::move(z)) {}

  static int Features(BlockKind kind) { return kind == BlockKind::kSlack ? 1 : 3 * Points(kind); }
  static int Points(BlockKind kind) { return kind == BlockKind::kPose ? 2 : 1; }

  template <typename T>
  Eigen::Matrix<T, Eigen::Dynamic, 1> Stack(std::span<const BlockState<T>> x) const {
    Eigen::Matrix<T, Eigen::Dynamic, 1> f(A_.cols());
    int row = 0;
    for (size_t s = 0; s < kinds_.size(); ++s) {
      if (kinds_[s] == BlockKind::kSlack) {
        f[row++] = x[s].slack();
        continue;
      }
      for (int k = 0; k < Points(kinds_[s]); ++k) {
        const Vector3<T> p = kinds_[s] == BlockKind::kPose
                                 ? Vector3<T>(x[s].R * kFeature[k].cast<T>() + x[s].t)
                                 : x[s].t;
        f.template segment<3>(row) = p;
        row += 3;
      }
    }
    return f;
  }

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Eigen::Matrix<T, Eigen::Dynamic, 1> f = Stack(x);
    for (int i = 0; i < A_.rows(); ++i) {
      T sum = T(-z_[i]);
      for (int j = 0; j < A_.cols(); ++j) sum += T(A_(i, j)) * f[j];
      r[i] = sum;
    }
  }

  bool is_linear() const override {
    return std::none_of(kinds_.begin(), kinds_.end(),
                        [](BlockKind k) { return k == BlockKind::kPose; });
  }

  std::string Describe(std::span<const std::string>) const override { return "mixed"; }

 private:
  static inline const Eigen::Vector3d kFeature[2] = {{0.3, -0.1, 0.2}, {-0.2, 0.25, 0.05}};
  std::vector<BlockKind> kinds_;
  Eigen::MatrixXd A_;
  Eigen::VectorXd z_;
};

// The features of `values` for slots `blocks`, in double (to make z consistent with a truth).
Eigen::VectorXd FeaturesAt(const MixedResidual& f, const std::vector<Block>& all,
                           const std::vector<int>& blocks, const Values& values) {
  std::vector<BlockState<double>> x;
  for (int b : blocks) {
    const Block& block = all[b];
    BlockState<double> s;
    s.R.setIdentity();
    s.t.setZero();
    if (block.kind == BlockKind::kPose) {
      s.R = values.poses[block.index].RotationMatrix();
      s.t = values.poses[block.index].translation;
    } else if (block.kind == BlockKind::kPoint) {
      s.t = values.points[block.index];
    } else {
      s.t.x() = values.slacks[block.index];
    }
    x.push_back(s);
  }
  return f.Stack<double>(x);
}

Eigen::MatrixXd RandomOrthogonal(int n, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  Eigen::MatrixXd M(n, n);
  for (int i = 0; i < M.size(); ++i) M(i) = g(rng);
  return Eigen::HouseholderQR<Eigen::MatrixXd>(M).householderQ();
}

// How badly conditioned a random Jacobian is.
enum class Shape { kWell, kDuplicateRow, kZeroRow, kRankDeficient, kNearSingular, kGraded };

// An m x cols matrix of the given shape, scaled by 10^U(-4, 4).
Eigen::MatrixXd RandomMatrix(int m, int cols, Shape shape, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const int k = std::min(m, cols);
  Eigen::VectorXd sv = Eigen::VectorXd::Ones(k);
  if (shape == Shape::kRankDeficient && k > 1) sv.tail(k / 2).setZero();
  if (shape == Shape::kNearSingular) sv[k - 1] = std::pow(10.0, -8 - 6 * u(rng));
  if (shape == Shape::kGraded) {
    for (int i = 0; i < k; ++i) sv[i] = std::pow(10.0, -12.0 * i / std::max(1, k - 1));
  }
  const Eigen::MatrixXd U = RandomOrthogonal(m, rng), V = RandomOrthogonal(cols, rng);
  Eigen::MatrixXd A = U.leftCols(k) * sv.asDiagonal() * V.leftCols(k).transpose();
  if (m > 1 && shape == Shape::kDuplicateRow) A.row(m - 1) = A.row(0);
  if (m > 1 && shape == Shape::kZeroRow) A.row(m - 1).setZero();
  return A * std::pow(10.0, 8 * u(rng) - 4);
}

// A random symmetric positive-definite matrix with condition number up to 1e4, times var.
Eigen::MatrixXd RandomNoise(int m, double variance, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  Eigen::VectorXd ev(m);
  for (int i = 0; i < m; ++i) ev[i] = std::pow(10.0, -4 * u(rng));
  const Eigen::MatrixXd Q = RandomOrthogonal(m, rng);
  Eigen::MatrixXd R = variance * Q * ev.asDiagonal() * Q.transpose();
  return 0.5 * (R + R.transpose());
}

struct Health {
  bool finite = true;
  double asymmetry = 0;  // max |P - Pᵀ| / max |P|
  double negative = 0;   // -(smallest eigenvalue) / the prior's trace, or 0
};

Health Check(const GaussianState& state, const Eigen::VectorXd& offset) {
  const Eigen::MatrixXd& P = state.covariance;
  Health h;
  h.finite = P.allFinite() && offset.allFinite();
  for (const Eigen::Vector3d& p : state.mean.points) h.finite = h.finite && p.allFinite();
  for (const Rigid3d& p : state.mean.poses) {
    h.finite = h.finite && p.translation.allFinite() && p.rotation.coeffs().allFinite();
  }
  for (double s : state.mean.slacks) h.finite = h.finite && std::isfinite(s);
  if (!h.finite) return h;
  const double scale = P.cwiseAbs().maxCoeff();
  h.asymmetry = scale > 0 ? (P - P.transpose()).cwiseAbs().maxCoeff() / scale : 0;
  const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues()(0);
  h.negative = std::max(0.0, -smallest / state.prior_variance.sum());
  return h;
}

// 4 points, 2 poses, 2 slacks: 26 tangent coordinates.
std::vector<Block> MixedBlocks() {
  std::vector<Block> blocks;
  int offset = 0;
  auto add = [&](BlockKind kind, int index) {
    blocks.push_back({kind, index, offset, "b" + std::to_string(blocks.size())});
    offset += TangentDim(kind);
  };
  for (int i = 0; i < 4; ++i) add(BlockKind::kPoint, i);
  for (int i = 0; i < 2; ++i) add(BlockKind::kPose, i);
  for (int i = 0; i < 2; ++i) add(BlockKind::kSlack, i);
  return blocks;
}

Values RandomValues(std::mt19937& rng, double spread) {
  std::normal_distribution<double> g(0, 1);
  Values v;
  for (int i = 0; i < 4; ++i) v.points.emplace_back(spread * g(rng), spread * g(rng), g(rng));
  for (int i = 0; i < 2; ++i) {
    v.poses.emplace_back(Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized(),
                         Eigen::Vector3d(spread * g(rng), spread * g(rng), spread * g(rng)));
  }
  for (int i = 0; i < 2; ++i) v.slacks.push_back(g(rng));
  return v;
}

// The covariance is exactly symmetric by construction (estimator.cpp). Its smallest eigenvalue
// is negative by roundoff only, relative to the largest variance the filter held (the prior's
// trace, as in estimator_test): about 1e-16 of it. But an update along a nearly determined
// direction, whose variance is a fraction ρ of its prior's, amplifies the roundoff already in
// the covariance by about 1/ρ, and ρ may be as small as FusionOptions::degeneracy_tolerance,
// 1e-12 (a limit of the covariance form, which a square-root filter would not have): 1e-4 of
// the prior's trace. So every check must be within 10 x that, and 99 % of them within 1e-9.
// Before the fixes of issue 8 this test found eigenvalues down to -16 x the prior's trace, 77 %
// of the checks within 1e-9, and 123 constraints fused again where they had just been fused
// changing the state.
constexpr double kNegative = 1e-3, kRoundoff = 1e-9;

// Episodes of 100 updates from a fresh prior (a solve's pass is shorter; the same covariance
// is never carried further), 1000 of them: 10^5 updates. Half fuse with Fuse's own
// iterations, moving the chart each time (a first pass, the interpretation tree); half as
// FuseSequence's Gauss-Newton passes do, every factor linearised at one point in one chart.
// Each update is a constraint (zero variance) or a measurement (variance 1e-8 to 1e8 x the
// prior's, itself 1e-6 to 1e6 m², with a noise covariance of condition up to 1e4; the prior's
// deviations 1e-3 to 1e3 m, 1e-3 to 1 rad, 1e-2 to 1e4 for slacks), of 1 to 6 rows on 1 to 3
// blocks, with a Jacobian well conditioned, with a duplicated or a zero row, of half rank, with a
// smallest singular value of 1e-8 to 1e-14, or graded down to 1e-12; or a constraint fused
// before, again (in the sequence mode any earlier one; in the moving chart the one just
// fused, which must change nothing there).
TEST_CASE("stress: 10^5 random updates keep the covariance symmetric, PSD and finite", "[stress]") {
  const std::vector<Block> blocks = MixedBlocks();
  std::mt19937 rng(20240808);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  std::uniform_int_distribution<int> pick_block(0, static_cast<int>(blocks.size()) - 1);
  const int episodes = 1000, updates_per_episode = 100, check_every = 10;
  int checks = 0, within_roundoff = 0, statuses[6] = {}, changed_by_refusion = 0;
  double worst = 0;
  for (int episode = 0; episode < episodes; ++episode) {
    const Values truth = RandomValues(rng, std::pow(10.0, 4 * u(rng) - 2));
    PriorScale scale;
    scale.position = std::pow(10.0, 6 * u(rng) - 3);
    scale.rotation = std::pow(10.0, 3 * u(rng) - 3);
    scale.slack = std::pow(10.0, 6 * u(rng) - 2);
    // The start: the truth moved by the prior's deviations (at most 0.3 m or rad).
    Values start = truth;
    Eigen::VectorXd jitter(blocks.back().tangent_offset + 1);
    for (const Block& b : blocks) {
      for (int i = 0; i < TangentDim(b.kind); ++i) {
        const double sigma = b.kind == BlockKind::kSlack           ? scale.slack
                             : b.kind == BlockKind::kPose && i < 3 ? scale.rotation
                                                                   : scale.position;
        jitter[b.tangent_offset + i] = std::min(sigma, 0.3) * g(rng);
      }
    }
    Retract(blocks, jitter, &start);
    GaussianState state = MakePrior(blocks, start, scale);
    const bool sequence_mode = episode % 2 == 1;
    Eigen::VectorXd offset = Eigen::VectorXd::Zero(state.dim());
    FusionOptions fusion;
    if (sequence_mode) fusion.max_iterations = 1;
    std::vector<Factor> fused_constraints;
    bool just_fused = false;  // the last update fused a constraint
    for (int update = 0; update < updates_per_episode; ++update) {
      Factor factor;
      std::ostringstream what;  // the update, for failure messages
      const bool again = sequence_mode ? !fused_constraints.empty() : just_fused;
      if (again && u(rng) < 0.15) {
        factor = sequence_mode ? fused_constraints[std::uniform_int_distribution<size_t>(
                                     0, fused_constraints.size() - 1)(rng)]
                               : fused_constraints.back();
        what << "a constraint fused before, again";
      } else {
        std::vector<int> slots;
        const int arity = 1 + static_cast<int>(3 * u(rng));
        while (static_cast<int>(slots.size()) < arity) {
          const int b = pick_block(rng);
          if (std::find(slots.begin(), slots.end(), b) == slots.end()) slots.push_back(b);
        }
        std::vector<BlockKind> kinds;
        int cols = 0;
        for (int b : slots) {
          kinds.push_back(blocks[b].kind);
          cols += MixedResidual::Features(blocks[b].kind);
        }
        const int m = std::min(cols, 1 + static_cast<int>(6 * u(rng)));
        const Shape shape = static_cast<Shape>(static_cast<int>(6 * u(rng)));
        const Eigen::MatrixXd A = RandomMatrix(m, cols, shape, rng);
        const bool constraint = u(rng) < 0.5;
        Eigen::VectorXd z =
            A * FeaturesAt(MixedResidual(kinds, A, Eigen::VectorXd::Zero(m)), blocks, slots, truth);
        Eigen::MatrixXd noise;
        if (!constraint) {
          const double variance = std::pow(10.0, 16 * u(rng) - 8) * A.squaredNorm() / m *
                                  scale.position * scale.position;
          noise = RandomNoise(m, variance, rng);
          // z drawn from the noise: consistent data, however wide.
          const Eigen::LLT<Eigen::MatrixXd> llt(noise);
          Eigen::VectorXd e(m);
          for (int i = 0; i < m; ++i) e[i] = g(rng);
          z += llt.matrixL() * e;
        }
        factor = {std::make_shared<MixedResidual>(kinds, A, z), slots, noise, "random"};
        what << (constraint ? "constraint" : "measurement") << " of " << m << " x " << cols
             << ", shape " << static_cast<int>(shape) << ", |A| " << A.norm();
        if (!constraint) what << ", variance " << noise.trace() / m;
      }
      const GaussianState before = state;
      const FusionSummary s =
          sequence_mode ? Fuse(factor, &state, fusion, &start, &offset) : Fuse(factor, &state);
      ++statuses[static_cast<int>(s.status)];
      what << ": " << StatusName(s.status) << " after " << s.iterations << " iterations";
      if (!s.changed_state()) {
        // Refused or redundant: nothing changed.
        REQUIRE(state.covariance == before.covariance);
      }
      if (!sequence_mode && again && factor.name == fused_constraints.back().name &&
          factor.residual == fused_constraints.back().residual) {
        // Fused again where it was just fused: every direction already determined, so redundant,
        // or refused as a contradiction if its first fusion left a residual (not converged).
        if (s.changed_state()) ++changed_by_refusion;
      }
      just_fused = factor.is_constraint() && s.changed_state();
      if (just_fused) fused_constraints.push_back(factor);
      if ((update + 1) % check_every == 0 || update + 1 == updates_per_episode) {
        if (sequence_mode && update + 1 == updates_per_episode) RetractOffset(&state, &offset);
        const Health h = Check(state, offset);
        ++checks;
        INFO("episode " << episode << " (" << (sequence_mode ? "sequence" : "moving chart")
                        << "), update " << update << ", the last " << what.str());
        REQUIRE(h.finite);
        CHECK(h.asymmetry <= 1e-15);
        CHECK(h.negative <= kNegative);
        within_roundoff += h.negative <= kRoundoff ? 1 : 0;
        worst = std::max(worst, h.negative);
      }
    }
  }
  INFO("worst negative eigenvalue / prior trace " << worst << "; within roundoff "
                                                  << within_roundoff << " of " << checks);
  CHECK(within_roundoff >= 0.99 * checks);
  // Every path was taken: fused, partly redundant, redundant, contradiction, invalid.
  for (int status : {0, 1, 2, 3, 5}) CHECK(statuses[status] > 0);
  CHECK(changed_by_refusion == 0);
}

}  // namespace
}  // namespace cfuse
