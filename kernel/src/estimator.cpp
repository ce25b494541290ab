#include "cfuse/kernel/estimator.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/so3.h"
#include "small_blas.h"

namespace cfuse {

using internal::CombineColumns;
using internal::ForwardSubstitute;
using internal::QuadraticForm;
using internal::ResetRotationBlock;
using internal::Run;
using internal::Scratch;
using internal::ScratchVector;
using internal::SmallProduct;
using internal::SmallProductTransposed;
using internal::SmallTransposedProduct;
using internal::SubtractOuterProduct;

const char* StatusName(FusionSummary::Status status) {
  switch (status) {
    case FusionSummary::Status::kFused:
      return "fused";
    case FusionSummary::Status::kPartlyRedundant:
      return "partly redundant";
    case FusionSummary::Status::kRedundant:
      return "redundant";
    case FusionSummary::Status::kContradiction:
      return "contradiction";
    case FusionSummary::Status::kNotConverged:
      return "not converged";
    case FusionSummary::Status::kInvalid:
      return "invalid";
  }
  return "?";
}

Eigen::VectorXd PriorVariance(const std::vector<Block>& blocks, const PriorScale& scale) {
  int n = 0;
  for (const Block& b : blocks) n = std::max(n, b.tangent_offset + TangentDim(b.kind));
  Eigen::VectorXd variance(n);
  for (const Block& b : blocks) {
    const int o = b.tangent_offset;
    switch (b.kind) {
      case BlockKind::kPoint:
        variance.segment<3>(o).setConstant(scale.position * scale.position);
        break;
      case BlockKind::kPose:
        variance.segment<3>(o).setConstant(scale.rotation * scale.rotation);
        variance.segment<3>(o + 3).setConstant(scale.position * scale.position);
        break;
      case BlockKind::kSlack:
        variance[o] = scale.slack * scale.slack;
        break;
    }
  }
  return variance;
}

GaussianState MakePrior(const std::vector<Block>& blocks, const Values& mean,
                        const PriorScale& scale) {
  GaussianState state;
  state.blocks = blocks;
  state.mean = mean;
  state.prior_variance = PriorVariance(blocks, scale);
  state.covariance = state.prior_variance.asDiagonal();
  state.groups = CorrelationGroups(static_cast<int>(blocks.size()));
  return state;
}

namespace {

struct Workspace {
  std::vector<int> index;           // the factor's tangent coordinates, slot order
  std::vector<int> support_blocks;  // blocks correlated with the factor's, by tangent offset
  std::vector<int> support;         // their tangent coordinates
  std::vector<int> position;        // where each of `index` sits in `support`
  std::vector<const double*> columns;     // where each column of the factor starts in P
  std::vector<const double*> aa_columns;  // and in P_aa
  std::vector<double> P_aa, prior_aa, delta, delta_a, mu, mu_a, next_a, r, H, S, S_init, innovation;
  std::vector<double> U, lambda, W, W_a, HP, A, z, Su, B, C, M, R, BRB, V, T, G, PG, Ti, v, Sv;
  std::vector<double> signs;
  std::vector<int> keep;
  std::vector<Run> runs;  // of the support
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen;
  Eigen::LLT<Eigen::MatrixXd> llt;
};

// Rows of a constraint whose prior covariance (scaled to unit diagonal) has an eigenvalue below
// this are combinations of the others: roundoff in an eigenvalue of that matrix is about 1e-16.
constexpr double kRankTolerance = 1e-12;
// Rows whose prior covariance (scaled to unit diagonal) has all its eigenvalues above this are
// far from dependent.
constexpr double kWellConditioned = 1e-6;

// The tangent coordinates the factor touches (the Jacobian's columns, `index`), and its
// support: every coordinate of the blocks correlated with them (`support`, as `runs`), with
// where each column sits in it (`position`).
void GatherSupport(const Factor& factor, const GaussianState& state, Workspace* ws) {
  const std::vector<Block>& blocks = state.blocks;
  ws->index.clear();
  for (int b : factor.blocks) {
    const Block& block = blocks.at(b);
    for (int i = 0; i < TangentDim(block.kind); ++i) ws->index.push_back(block.tangent_offset + i);
  }
  if (state.groups.num_blocks() == static_cast<int>(blocks.size())) {
    state.groups.Support(factor.blocks, &ws->support_blocks);
  } else {
    ws->support_blocks.resize(blocks.size());
    std::iota(ws->support_blocks.begin(), ws->support_blocks.end(), 0);
  }
  // Blocks are usually laid out in id order already (ModelBuilder), so the sort is rare.
  const auto by_offset = [&](int x, int y) {
    return blocks[x].tangent_offset < blocks[y].tangent_offset;
  };
  if (!std::is_sorted(ws->support_blocks.begin(), ws->support_blocks.end(), by_offset)) {
    std::sort(ws->support_blocks.begin(), ws->support_blocks.end(), by_offset);
  }
  ws->runs.clear();
  int s = 0;
  for (int b : ws->support_blocks) {
    const int first = blocks[b].tangent_offset, dim = TangentDim(blocks[b].kind);
    if (!ws->runs.empty() && ws->runs.back().first + ws->runs.back().size == first) {
      ws->runs.back().size += dim;
    } else {
      ws->runs.push_back({first, s, dim});
    }
    s += dim;
  }
  ws->support.resize(s);
  for (const Run& run : ws->runs) {
    std::iota(ws->support.begin() + run.at, ws->support.begin() + run.at + run.size, run.first);
  }
  // Each column's place in the support, through the run holding it (runs are few and sorted).
  const int a = static_cast<int>(ws->index.size());
  ws->position.resize(a);
  for (int j = 0; j < a; ++j) {
    const int coordinate = ws->index[j];
    const auto run = std::upper_bound(ws->runs.begin(), ws->runs.end(), coordinate,
                                      [](int x, const Run& r) { return x < r.first; });
    CFUSE_CHECK(run != ws->runs.begin());
    const Run& held = *std::prev(run);
    CFUSE_CHECK(coordinate < held.first + held.size);
    ws->position[j] = held.at + coordinate - held.first;
  }
}

// The update's prior on the support: where P(S, a)'s columns start in P, P(a, a) and the
// columns' prior variances; its prior mean μ in the chart (0, or the offset the sequence
// carries) and the first iterate δ (μ, or `linearize_at` on the factor's blocks), over the
// support and over its columns.
void GatherPrior(const Factor& factor, const GaussianState& state, const Values* linearize_at,
                 const Eigen::VectorXd* offset, Workspace* ws) {
  const std::vector<Block>& blocks = state.blocks;
  const Eigen::MatrixXd& P = state.covariance;
  const std::vector<int>& S = ws->support;
  const int s = static_cast<int>(S.size()), a = static_cast<int>(ws->index.size());
  const int n = state.dim();
  // P(S, a) is read in place (the covariance does not change until the update's end).
  ws->columns.resize(a);
  for (int j = 0; j < a; ++j) ws->columns[j] = P.data() + static_cast<long>(ws->index[j]) * n;
  Eigen::Map<Eigen::MatrixXd> P_aa = Scratch(&ws->P_aa, a, a);
  ws->aa_columns.resize(a);
  for (int j = 0; j < a; ++j) {
    for (int i = 0; i < a; ++i) P_aa(i, j) = ws->columns[j][ws->index[i]];
    ws->aa_columns[j] = P_aa.data() + static_cast<long>(j) * a;
  }
  Eigen::Map<Eigen::VectorXd> prior_a = ScratchVector(&ws->prior_aa, a);
  for (int j = 0; j < a; ++j) prior_a(j) = state.prior_variance[ws->index[j]];

  // δ over the support; the iterations start at `linearize_at` if given.
  Eigen::Map<Eigen::VectorXd> delta = ScratchVector(&ws->delta, s);
  Eigen::Map<Eigen::VectorXd> delta_a = ScratchVector(&ws->delta_a, a);
  // The prior mean of this update in the chart: 0, or the offset carried by the sequence.
  Eigen::Map<Eigen::VectorXd> mu = ScratchVector(&ws->mu, s);
  Eigen::Map<Eigen::VectorXd> mu_a = ScratchVector(&ws->mu_a, a);
  if (offset) {
    CFUSE_CHECK_EQ(offset->size(), n);
    for (int j = 0; j < s; ++j) mu(j) = (*offset)(S[j]);
  } else {
    mu.setZero();
  }
  for (int j = 0; j < a; ++j) mu_a(j) = mu(ws->position[j]);
  delta = mu;
  delta_a = mu_a;
  if (linearize_at) {
    int column = 0;
    for (int b : factor.blocks) {
      LocalCoordinatesOfBlock(blocks[b], state.mean, *linearize_at, delta_a.data() + column);
      column += TangentDim(blocks[b].kind);
    }
    for (int j = 0; j < a; ++j) delta(ws->position[j]) = delta_a(j);
  }
}

// A measurement's whitened directions (B = L⁻ᵀ with S = H P0 Hᵀ + R = L Lᵀ): A = Hᵀ B and
// z = Bᵀ innovation, and M = Aᵀ P0 A + Bᵀ R B for the Joseph form. False when S is not
// positive definite.
bool WhitenMeasurement(const Eigen::MatrixXd& noise, const Eigen::Map<Eigen::MatrixXd>& H,
                       const Eigen::Map<Eigen::MatrixXd>& P_aa,
                       const Eigen::Map<Eigen::VectorXd>& innovation, Workspace* ws) {
  const int m = static_cast<int>(H.rows()), a = static_cast<int>(H.cols());
  Eigen::Map<Eigen::MatrixXd> HP = Scratch(&ws->HP, m, a), S_mat = Scratch(&ws->S, m, m);
  Eigen::Map<Eigen::MatrixXd> A = Scratch(&ws->A, a, m);
  Eigen::Map<Eigen::VectorXd> z = ScratchVector(&ws->z, m);
  SmallProduct(H, P_aa, &HP);
  SmallProductTransposed(HP, H, &S_mat);
  S_mat += noise;
  ws->llt.compute(S_mat);
  if (ws->llt.info() != Eigen::Success) return false;
  A = H.transpose();
  z = innovation;
  ForwardSubstitute(ws->llt.matrixLLT(), &A, &z);
  // M = Aᵀ P0 A + Bᵀ R B with B = L⁻ᵀ, for the Joseph form below (from the A used: its
  // roundoff is what the Joseph form absorbs).
  Eigen::Map<Eigen::MatrixXd> M = Scratch(&ws->M, m, m), B = Scratch(&ws->B, m, m);
  Eigen::Map<Eigen::VectorXd> unused = ScratchVector(&ws->Su, m);
  B.setIdentity();
  ForwardSubstitute(ws->llt.matrixLLT(), &B, &unused);
  Eigen::Map<Eigen::MatrixXd> R = Scratch(&ws->R, m, m), BRB = Scratch(&ws->BRB, m, m);
  R = noise;
  QuadraticForm(A, P_aa, &ws->PG, &M);
  QuadraticForm(B, R, &ws->PG, &BRB);
  M += BRB;
  return true;
}

// WhitenMeasurement for three rows, the commonest measurement (a 3D point or marker): the same
// quantities in fixed-size matrices, whose dynamic counterparts' set-up (a dynamic LLT, its
// triangular solves, the quadratic forms' scratch) cost more than a 3 x 3 update's arithmetic.
bool WhitenMeasurement3(const Eigen::MatrixXd& noise, const Eigen::Map<Eigen::MatrixXd>& H,
                        const Eigen::Map<Eigen::MatrixXd>& P_aa,
                        const Eigen::Map<Eigen::VectorXd>& innovation, Workspace* ws) {
  const int a = static_cast<int>(H.cols());
  using Rows3 = Eigen::Matrix<double, 3, Eigen::Dynamic>;
  Eigen::Map<Rows3> HP(Scratch(&ws->HP, 3, a).data(), 3, a);
  for (int l = 0; l < a; ++l) {
    HP.col(l).setZero();
    for (int j = 0; j < a; ++j) HP.col(l) += H.col(j) * P_aa(j, l);
  }
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (int l = 0; l < a; ++l) S.noalias() += HP.col(l) * H.col(l).transpose();
  S += noise;
  const Eigen::LLT<Eigen::Matrix3d> llt(S);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::Matrix3d L = llt.matrixL();
  // Aᵀ = L⁻¹ H, z = L⁻¹ innovation and Bᵀ = L⁻¹, by forward substitution (more accurate than
  // multiplying by an inverse where S is ill-conditioned).
  Eigen::Map<Rows3> At(Scratch(&ws->G, 3, a).data(), 3, a);
  Eigen::Vector3d z = innovation;
  Eigen::Matrix3d Bt = Eigen::Matrix3d::Identity();
  At = H;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < i; ++j) {
      At.row(i) -= L(i, j) * At.row(j);
      z(i) -= L(i, j) * z(j);
      Bt.row(i) -= L(i, j) * Bt.row(j);
    }
    At.row(i) /= L(i, i);
    z(i) /= L(i, i);
    Bt.row(i) /= L(i, i);
  }
  Scratch(&ws->A, a, 3) = At.transpose();
  ScratchVector(&ws->z, 3) = z;
  // M = Aᵀ P0 A + Bᵀ R B, from the A used (its roundoff is what the Joseph form absorbs).
  Eigen::Map<Rows3> AP(Scratch(&ws->PG, 3, a).data(), 3, a);
  for (int l = 0; l < a; ++l) {
    AP.col(l).setZero();
    for (int j = 0; j < a; ++j) AP.col(l) += At.col(j) * P_aa(j, l);
  }
  Eigen::Matrix3d M = Bt * noise * Bt.transpose();
  for (int l = 0; l < a; ++l) M.noalias() += AP.col(l) * At.col(l).transpose();
  Scratch(&ws->M, 3, 3) = 0.5 * (M + M.transpose());
  return true;
}

// WhitenConstraint (below) for a single row, the commonest constraint (a distance, an angle, a
// limit): the same quantities without its small dynamic matrices, whose set-up cost more than
// the row's products.
int WhitenScalarConstraint(const Eigen::Map<Eigen::MatrixXd>& H,
                           const Eigen::Map<Eigen::VectorXd>& prior_a, double innovation,
                           bool first, const FusionOptions& options, Workspace* ws,
                           FusionSummary* summary) {
  const int a = static_cast<int>(H.cols());
  double s_init = 0;
  for (int l = 0; l < a; ++l) s_init += H(0, l) * prior_a(l) * H(0, l);
  // The row scaled to unit prior variance (t), and ρ = tᵀ S t = Gᵀ P(a, a) G, the fraction of
  // it left.
  const double t = s_init > 0 ? 1 / std::sqrt(s_init) : 0.0;
  Eigen::Map<Eigen::MatrixXd> G = Scratch(&ws->G, a, 1);
  for (int l = 0; l < a; ++l) G(l, 0) = H(0, l) * t;
  Eigen::Map<Eigen::VectorXd> PG = ScratchVector(&ws->PG, a);
  double rho = 0;
  if (t > 0) {
    CombineColumns(ws->aa_columns.data(), 0, a, a, G.data(), PG.data());
    for (int l = 0; l < a; ++l) rho += G(l, 0) * PG(l);
  }
  const bool kept = t > 0 && rho > options.degeneracy_tolerance;
  if (first) {
    // Already determined: consistent only if the innovation has no component along t.
    summary->contradiction = t > 0 && !kept ? std::abs(t * innovation) : 0.0;
    if (summary->contradiction > options.contradiction_tolerance) {
      summary->status = FusionSummary::Status::kContradiction;
      return -1;
    }
    if (!kept) {
      summary->status = FusionSummary::Status::kRedundant;
      return -1;
    }
    summary->rows_fused = 1;
  }
  if (!kept) return 0;
  const double scale = 1 / std::sqrt(rho);
  Scratch(&ws->A, a, 1) = G * scale;
  ScratchVector(&ws->z, 1)(0) = scale * t * innovation;
  Scratch(&ws->M, 1, 1)(0, 0) = rho / std::sqrt(rho) / std::sqrt(rho);
  return 1;
}

// A constraint's whitened directions: A = Hᵀ B and z = Bᵀ innovation over the directions it
// still constrains, B = t ρ^(-1/2), and M = Aᵀ P0 A for the Joseph form. Returns their number
// k; 0 when none is left; -1 (with the status in `summary`) when the first iteration finds the
// constraint contradicting the state or wholly redundant.
int WhitenConstraint(const Eigen::Map<Eigen::MatrixXd>& H, const Eigen::Map<Eigen::MatrixXd>& P_aa,
                     const Eigen::Map<Eigen::VectorXd>& prior_a,
                     const Eigen::Map<Eigen::VectorXd>& innovation, bool first,
                     const FusionOptions& options, Workspace* ws, FusionSummary* summary) {
  const int m = static_cast<int>(H.rows()), a = static_cast<int>(H.cols());
  if (m == 1) {
    return WhitenScalarConstraint(H, prior_a, innovation(0), first, options, ws, summary);
  }
  Eigen::Map<Eigen::MatrixXd> HP = Scratch(&ws->HP, m, a), S_mat = Scratch(&ws->S, m, m);
  Eigen::Map<Eigen::MatrixXd> S_init = Scratch(&ws->S_init, m, m), U = Scratch(&ws->U, m, m);
  Eigen::Map<Eigen::VectorXd> lambda = ScratchVector(&ws->lambda, m);
  Eigen::Map<Eigen::MatrixXd> A = Scratch(&ws->A, a, m);
  Eigen::Map<Eigen::VectorXd> z = ScratchVector(&ws->z, m);
  // The directions of the residual space, each normalised to unit variance under the
  // initial prior (tᵀ S_init t = 1), with ρ = tᵀ S t the fraction of it left: a direction
  // with ρ negligible is already determined. Rows that are (numerically) combinations of
  // others have no direction of their own: found on the rows scaled to unit prior variance,
  // where every eigenvalue is relative to 1. Without that test their direction had roundoff
  // for both variances and, when the ratio passed the tolerance, was fused with a garbage
  // gain that broke the covariance's positive semidefiniteness (tests/stress).
  HP.noalias() = H * prior_a.asDiagonal();
  SmallProductTransposed(HP, H, &S_init);
  Eigen::Map<Eigen::VectorXd> d = ScratchVector(&ws->Su, m);
  for (int i = 0; i < m; ++i) d(i) = S_init(i, i) > 0 ? 1 / std::sqrt(S_init(i, i)) : 0.0;
  for (int j = 0; j < m; ++j) {
    for (int i = 0; i < m; ++i) S_init(i, j) *= d(i) * d(j);
  }
  // T (m x rank): the directions, or (below) a basis of them.
  Eigen::Map<Eigen::MatrixXd> T = Scratch(&ws->T, m, m);
  int rank = 0;
  double contradiction = 0;
  ws->eigen.compute(S_init);
  for (int i = 0; i < m; ++i) {
    const double mu = ws->eigen.eigenvalues()(i);
    if (mu > kRankTolerance * m) {
      T.col(rank++) = d.cwiseProduct(ws->eigen.eigenvectors().col(i)) / std::sqrt(mu);
    } else if (first) {
      // Consistent only if the rows' innovations are the same combination (measured in the
      // rows' prior deviations).
      contradiction = std::max(
          contradiction, std::abs(d.cwiseProduct(ws->eigen.eigenvectors().col(i)).dot(innovation)));
    }
  }
  // The variances on T, Tᵀ S T, as Gᵀ P0 G with G = Hᵀ T: forming S = H P0 Hᵀ first loses
  // them to cancellation where rows are nearly dependent (T then large).
  Eigen::Map<Eigen::MatrixXd> Tr = Scratch(&ws->T, m, rank), G = Scratch(&ws->G, a, rank);
  Eigen::Map<Eigen::MatrixXd> Sr = Scratch(&ws->C, rank, rank);
  const bool well_conditioned = rank == m && ws->eigen.eigenvalues()(0) > kWellConditioned;
  if (well_conditioned) {
    // Rows far from dependent: the eigenvectors u of S, accurate there (the directions the
    // filter always took for such rows, with which the interpretation tree's gates were tuned).
    SmallProduct(H, P_aa, &HP);
    SmallProductTransposed(HP, H, &S_mat);
    ws->eigen.compute(S_mat);
    Eigen::Map<Eigen::VectorXd> v = ScratchVector(&ws->v, m), Sv = ScratchVector(&ws->Sv, m);
    for (int j = 0; j < m; ++j) {
      v = ws->eigen.eigenvectors().col(j).cwiseQuotient(d);  // uᵀ S_init u = vᵀ (scaled) v
      Sv.noalias() = S_init * v;
      Tr.col(j) = ws->eigen.eigenvectors().col(j) / std::sqrt(v.dot(Sv));
    }
    SmallTransposedProduct(H, Tr, &G);
    QuadraticForm(G, P_aa, &ws->PG, &Sr);
    U.topLeftCorner(m, m).setIdentity();
    lambda.head(m) = Sr.diagonal();
  } else {
    // Else the generalised eigenvectors of (S, S_init) on the rows' range.
    SmallTransposedProduct(H, Tr, &G);
    QuadraticForm(G, P_aa, &ws->PG, &Sr);
    if (rank == 1) {
      U(0, 0) = 1;
      lambda(0) = Sr(0, 0);
    } else if (rank > 1) {
      ws->eigen.compute(Sr);
      U.topLeftCorner(rank, rank) = ws->eigen.eigenvectors();
      lambda.head(rank) = ws->eigen.eigenvalues();
    }
  }
  // The innovation on T, for the contradiction test.
  Eigen::Map<Eigen::VectorXd> Ti = ScratchVector(&ws->Ti, rank);
  for (int j = 0; j < rank; ++j) Ti(j) = Tr.col(j).dot(innovation);
  ws->keep.clear();
  for (int i = 0; i < rank; ++i) {
    if (lambda(i) <= options.degeneracy_tolerance) {
      // Already determined: the linearised factor is consistent only if its innovation
      // has no component along t (the state cannot move along Hᵀt).
      if (first) {
        contradiction = std::max(contradiction, std::abs(U.col(i).head(rank).dot(Ti)));
      }
      continue;
    }
    ws->keep.push_back(i);
  }
  if (first) {
    summary->contradiction = contradiction;
    if (contradiction > options.contradiction_tolerance) {
      summary->status = FusionSummary::Status::kContradiction;
      return -1;
    }
    if (ws->keep.empty()) {
      summary->status = FusionSummary::Status::kRedundant;
      return -1;
    }
    summary->rows_fused = static_cast<int>(ws->keep.size());
  }
  // Later iterations keep the directions of the first (a direction's status cannot change
  // between them without a contradiction, which the first iteration refused).
  // Nothing left to fuse (at the final iterate: the previous linearisation's covariance
  // update then stands, its A and W still in place).
  if (ws->keep.empty()) return 0;
  const int k = static_cast<int>(ws->keep.size());
  Eigen::Map<Eigen::MatrixXd> B = Scratch(&ws->B, m, k);
  for (int j = 0; j < k; ++j) {
    const double scale = 1 / std::sqrt(lambda(ws->keep[j]));
    B.col(j).setZero();
    A.col(j).setZero();
    for (int l = 0; l < rank; ++l) {
      const double q = U(l, ws->keep[j]) * scale;
      B.col(j) += q * Tr.col(l);
      A.col(j) += q * G.col(l);
    }
    z(j) = B.col(j).dot(innovation);
  }
  // M = Aᵀ P0 A, for the Joseph form below: from the A used, as roundoff in it is what the
  // Joseph form absorbs. Where U = I (one direction, or S's eigenvectors), each column of A is a
  // column of G times its scale, so M is Sr = Gᵀ P0 G scaled on both sides: the same products.
  Eigen::Map<Eigen::MatrixXd> M = Scratch(&ws->M, k, k);
  if (well_conditioned || rank == 1) {
    for (int j = 0; j < k; ++j) {
      for (int i = 0; i <= j; ++i) {
        M(i, j) = M(j, i) = Sr(ws->keep[i], ws->keep[j]) / std::sqrt(lambda(ws->keep[i])) /
                            std::sqrt(lambda(ws->keep[j]));
      }
    }
  } else {
    QuadraticForm(Scratch(&ws->A, a, k), P_aa, &ws->PG, &M);
  }
  return k;
}

// The gain over the whole support, W = P(S, a) A (s x k), from the whitened directions A.
void GainOnSupport(int k, Workspace* ws) {
  const int s = static_cast<int>(ws->support.size()), a = static_cast<int>(ws->index.size());
  Eigen::Map<Eigen::MatrixXd> A = Scratch(&ws->A, a, k), W = Scratch(&ws->W, s, k);
  for (int j = 0; j < k; ++j) {
    for (const Run& run : ws->runs) {
      CombineColumns(ws->columns.data(), run.first, run.size, a, A.col(j).data(),
                     W.col(j).data() + run.at);
    }
  }
}

// The iterate that stands, over the whole support: δ = μ + W z.
void StepOnSupport(int k, Workspace* ws) {
  GainOnSupport(k, ws);
  const int s = static_cast<int>(ws->support.size()), a = static_cast<int>(ws->index.size());
  Eigen::Map<Eigen::MatrixXd> W = Scratch(&ws->W, s, k);
  Eigen::Map<Eigen::VectorXd> delta = ScratchVector(&ws->delta, s);
  delta = ScratchVector(&ws->mu, s);
  for (int j = 0; j < k; ++j) delta += ws->z[j] * W.col(j);
  Eigen::Map<Eigen::VectorXd> delta_a = ScratchVector(&ws->delta_a, a);
  for (int j = 0; j < a; ++j) delta_a(j) = delta(ws->position[j]);
}

// The covariance for the final linearisation, on the support only, in Joseph form:
// (I - K H) P0 (I - K H)ᵀ + K R Kᵀ = P0 - W (2I - M) Wᵀ with M = Bᵀ (H P0 Hᵀ + R) B (above),
// which is I for the exact optimal gain and then gives P0 - W Wᵀ. Roundoff makes the gain
// inexact (a nearly determined or nearly dependent direction); P0 - W Wᵀ then lost positive
// semidefiniteness (tests/stress: eigenvalues down to -16 x the prior's trace), while the error of
// the Joseph form is of second order in the gain's.
void JosephUpdate(int k, Workspace* ws, Eigen::MatrixXd* covariance) {
  const int s = static_cast<int>(ws->support.size());
  Eigen::Map<Eigen::MatrixXd> C = Scratch(&ws->C, k, k);
  C = 2 * Eigen::MatrixXd::Identity(k, k) - Scratch(&ws->M, k, k);
  // P0 -= W (2I - M) Wᵀ as rank-one steps: 2I - M = L Lᵀ (it is near I), P0 -= (W L)(W L)ᵀ;
  // else 2I - M = Q diag(c) Qᵀ, P0 -= Σ_j sign(c_j) v_j v_jᵀ with v_j = W q_j |c_j|^½.
  Eigen::Map<Eigen::MatrixXd> W = Scratch(&ws->W, s, k), V = Scratch(&ws->V, s, k);
  Eigen::Map<Eigen::VectorXd> signs = ScratchVector(&ws->signs, k);
  signs.setOnes();
  Eigen::LLT<Eigen::Matrix3d> llt3;
  if (k == 1) {
    signs(0) = C(0, 0) < 0 ? -1 : 1;
    W *= std::sqrt(std::abs(C(0, 0)));
  } else if (k == 3 && llt3.compute(Eigen::Matrix3d(C)).info() == Eigen::Success) {
    const Eigen::Matrix3d L = llt3.matrixL();
    for (int j = 0; j < 3; ++j) {
      V.col(j) = W.col(j) * L(j, j);
      for (int l = j + 1; l < 3; ++l) V.col(j) += W.col(l) * L(l, j);
    }
    W = V;
  } else if (ws->llt.compute(C).info() == Eigen::Success) {
    const auto& L = ws->llt.matrixLLT();  // lower triangle
    for (int j = 0; j < k; ++j) {
      V.col(j) = W.col(j) * L(j, j);
      for (int l = j + 1; l < k; ++l) V.col(j) += W.col(l) * L(l, j);
    }
    W = V;
  } else {
    ws->eigen.compute(C);
    V.noalias() = W * ws->eigen.eigenvectors();
    for (int j = 0; j < k; ++j) {
      const double c = ws->eigen.eigenvalues()(j);
      signs(j) = c < 0 ? -1 : 1;
      W.col(j) = V.col(j) * std::sqrt(std::abs(c));
    }
  }
  SubtractOuterProduct(ws->runs, W, signs.data(), covariance);
}

// Moves the mean and the covariance to the chart at x0 ⊞ δ*.
void RetractSupport(const Eigen::Map<Eigen::VectorXd>& delta, const Workspace& ws,
                    GaussianState* state) {
  int at = 0;
  for (int b : ws.support_blocks) {
    const Block& block = state->blocks[b];
    RetractBlock(block, delta.data() + at, &state->mean);
    if (block.kind == BlockKind::kPose) {
      const Eigen::Vector3d w = delta.segment<3>(at);
      if (!w.isZero()) {
        ResetRotationBlock(ws.runs, block.tangent_offset, RightJacobianSO3(w), &state->covariance);
      }
    }
    at += TangentDim(block.kind);
  }
}

}  // namespace

FusionSummary Fuse(const Factor& factor, GaussianState* state, const FusionOptions& options,
                   const Values* linearize_at, Eigen::VectorXd* offset) {
  const ResidualFunction& f = *factor.residual;
  const int m = f.dimension(), n = state->dim();
  FusionSummary summary;
  summary.rows = m;
  CFUSE_CHECK(factor.is_constraint() || (factor.noise.rows() == m && factor.noise.cols() == m));
  const std::vector<Block>& blocks = state->blocks;
  thread_local Workspace ws;

  GatherSupport(factor, *state, &ws);
  const int a = static_cast<int>(ws.index.size());
  CFUSE_CHECK_EQ(a, f.arity());
  const std::vector<int>& S = ws.support;
  const int s = static_cast<int>(S.size());
  CFUSE_CHECK_EQ(state->covariance.rows(), n);
  CFUSE_CHECK_EQ(state->covariance.cols(), n);
  GatherPrior(factor, *state, linearize_at, offset, &ws);
  const Eigen::Map<Eigen::MatrixXd> P_aa = Scratch(&ws.P_aa, a, a);
  const Eigen::Map<Eigen::VectorXd> prior_a = ScratchVector(&ws.prior_aa, a);
  const Eigen::Map<Eigen::VectorXd> mu_a = ScratchVector(&ws.mu_a, a);
  Eigen::Map<Eigen::VectorXd> delta = ScratchVector(&ws.delta, s);
  Eigen::Map<Eigen::VectorXd> delta_a = ScratchVector(&ws.delta_a, a);

  Eigen::Map<Eigen::VectorXd> r = ScratchVector(&ws.r, m);
  Eigen::Map<Eigen::MatrixXd> H = Scratch(&ws.H, m, a);
  Eigen::Map<Eigen::VectorXd> innovation = ScratchVector(&ws.innovation, m);
  Eigen::Map<Eigen::VectorXd> next_a = ScratchVector(&ws.next_a, a);
  // Each iteration whitens the directions it fuses: with B (m x k) such that Bᵀ (H P0 Hᵀ + R) B
  // is the identity, A = Hᵀ B (a x k), W = P0 A (s x k on the support) and z = Bᵀ innovation
  // (k), the step is δ = W z and the covariance update P0 - W Wᵀ (in Joseph form, below). For
  // a measurement B = L⁻ᵀ with S = L Lᵀ (S >= R > 0: no direction can be degenerate); for a
  // constraint B = t ρ^(-1/2) over its kept directions t (below).
  const bool linear = f.is_linear();
  int k = 0;
  // Once the iterate has moved by more than the tolerance, its final linearisation is
  // evaluated once more, for the covariance only: one from the Jacobian at the previous iterate
  // left the factor's directions at the new mean nearly (not exactly) determined, and a later
  // update along them amplified roundoff by the inverse of their tiny variance (tests/stress:
  // eigenvalues down to -0.03 x the prior's trace, and a constraint fused again at once still
  // moved the state). Not in a Gauss-Newton pass (max_iterations 1), whose updates must all be
  // linearised at one point, nor where the covariance is discarded
  // (FusionOptions::covariance_at_final_iterate).
  bool finishing = false;
  // Where the iterations relinearise, a constraint's check of its residual at the new iterate
  // (below) differentiates it too: the next iteration, or the finishing one, needs that
  // Jacobian at the same point.
  const bool relinearise = options.max_iterations > 1 && options.covariance_at_final_iterate;
  bool evaluated = false;  // r and H already at the current iterate
  for (int iteration = 0; iteration < options.max_iterations || finishing; ++iteration) {
    if (!evaluated) {
      EvaluateResidualAt(f, blocks, factor.blocks, state->mean, delta_a.data(), r.data(), H.data());
    }
    evaluated = false;
    if (!r.allFinite() || !H.allFinite()) {
      summary.status = FusionSummary::Status::kInvalid;
      for (int i = 0; i < m && summary.invalid_row < 0; ++i) {
        if (!std::isfinite(r(i)) || !H.row(i).allFinite()) summary.invalid_row = i;
      }
      return summary;
    }
    // The innovation H δ - r; then S = H P0 Hᵀ (+ R) whitened (small_blas.h).
    for (int i = 0; i < m; ++i) innovation(i) = H.row(i).dot(delta_a - mu_a) - r(i);

    Eigen::Map<Eigen::MatrixXd> A = Scratch(&ws.A, a, m);
    Eigen::Map<Eigen::VectorXd> z = ScratchVector(&ws.z, m);
    if (!factor.is_constraint()) {
      const bool whitened = m == 3 ? WhitenMeasurement3(factor.noise, H, P_aa, innovation, &ws)
                                   : WhitenMeasurement(factor.noise, H, P_aa, innovation, &ws);
      if (!whitened) {
        summary.status = FusionSummary::Status::kInvalid;
        return summary;
      }
      k = m;
      if (iteration == 0) summary.rows_fused = m;
    } else {
      const int kept =
          WhitenConstraint(H, P_aa, prior_a, innovation, iteration == 0, options, &ws, &summary);
      if (kept < 0) return summary;
      if (finishing && kept == 0) break;
      k = kept;
    }
    if (finishing) {
      GainOnSupport(k, &ws);
      break;
    }
    if (iteration == 0) summary.innovation_nis = z.head(k).squaredNorm();
    summary.final_nis = z.head(k).squaredNorm();
    summary.iterations = iteration + 1;
    // An affine residual is solved exactly by its first update.
    if (linear) {
      StepOnSupport(k, &ws);
      break;
    }
    // The iterate on the factor's own coordinates: the rows of W at its columns are
    // P(a, a) A. Only the iterate that stands needs W over the whole support (StepOnSupport).
    Eigen::Map<Eigen::MatrixXd> W_a = Scratch(&ws.W_a, a, k);
    for (int j = 0; j < k; ++j) {
      CombineColumns(ws.aa_columns.data(), 0, a, a, A.col(j).data(), W_a.col(j).data());
    }
    next_a = mu_a;
    for (int j = 0; j < k; ++j) next_a += z(j) * W_a.col(j);
    const double step = (next_a - delta_a).lpNorm<Eigen::Infinity>();
    delta_a = next_a;
    if (step <= options.step_tolerance * (1 + delta_a.lpNorm<Eigen::Infinity>())) {
      StepOnSupport(k, &ws);
      break;
    }
    if (factor.is_constraint()) {
      // A constraint met at the new iterate needs no further step (the next would be of the
      // size of its residual).
      EvaluateResidualAt(f, blocks, factor.blocks, state->mean, delta_a.data(), r.data(),
                         relinearise ? H.data() : nullptr);
      evaluated = relinearise;
      if (r.allFinite() && r.lpNorm<Eigen::Infinity>() <= options.residual_tolerance) {
        StepOnSupport(k, &ws);
        if (!relinearise) break;
        finishing = true;
        continue;
      }
    }
    if (iteration + 1 == options.max_iterations) {
      StepOnSupport(k, &ws);
      if (!relinearise) break;
      summary.status = FusionSummary::Status::kNotConverged;
      finishing = true;
    }
  }

  if (k > 0) JosephUpdate(k, &ws, &state->covariance);
  if (offset) {
    // The sequence carries the estimate in the chart; RetractOffset() moves it at the end.
    for (int j = 0; j < s; ++j) (*offset)(S[j]) = delta(j);
  } else {
    RetractSupport(delta, ws, state);
  }
  if (state->groups.num_blocks() == static_cast<int>(blocks.size())) {
    state->groups.Merge(factor.blocks);
  }
  if (summary.status == FusionSummary::Status::kFused && summary.rows_fused < m) {
    summary.status = FusionSummary::Status::kPartlyRedundant;
  }
  return summary;
}

void RetractOffset(GaussianState* state, Eigen::VectorXd* offset) {
  const int n = state->dim();
  CFUSE_CHECK_EQ(offset->size(), n);
  const std::vector<Run> all = {{0, 0, n}};
  for (const Block& block : state->blocks) {
    const double* d = offset->data() + block.tangent_offset;
    RetractBlock(block, d, &state->mean);
    if (block.kind == BlockKind::kPose) {
      const Eigen::Vector3d w(d[0], d[1], d[2]);
      if (!w.isZero()) {
        ResetRotationBlock(all, block.tangent_offset, RightJacobianSO3(w), &state->covariance);
      }
    }
  }
  offset->setZero();
}

Prediction Predict(const Factor& factor, const GaussianState& state) {
  const ResidualFunction& f = *factor.residual;
  Prediction p;
  // (Called for every edge of every predicted frame: the work matrices are kept per thread.)
  thread_local Eigen::MatrixXd H, P;
  thread_local std::vector<int> index;
  EvaluateResidual(f, state.blocks, factor.blocks, state.mean, &p.mean, &H);
  if (!p.mean.allFinite() || !H.allFinite()) return p;
  index.clear();
  for (int b : factor.blocks) {
    const Block& block = state.blocks.at(b);
    for (int i = 0; i < TangentDim(block.kind); ++i) index.push_back(block.tangent_offset + i);
  }
  P = state.covariance(index, index);
  p.covariance.noalias() = H * P * H.transpose();
  // Symmetric to the last bit: both halves the same mean (the sum commutes exactly).
  for (Eigen::Index j = 0; j < p.covariance.cols(); ++j) {
    for (Eigen::Index i = 0; i < j; ++i) {
      const double mean = 0.5 * (p.covariance(i, j) + p.covariance(j, i));
      p.covariance(i, j) = p.covariance(j, i) = mean;
    }
  }
  p.valid = p.covariance.allFinite();
  return p;
}

double MaxConstraintResidual(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                             const Values& values) {
  double worst = 0;
  thread_local std::vector<double> r;
  for (const Factor& f : factors) {
    if (!f.is_constraint()) continue;
    r.resize(f.residual->dimension());
    EvaluateResidualAt(*f.residual, blocks, f.blocks, values, nullptr, r.data(), nullptr);
    for (double v : r) worst = std::max(worst, std::isnan(v) ? INFINITY : std::abs(v));
  }
  return worst;
}

namespace {

// An inequality g(x) - λ² = 0 whose slack has reached 0 (the constraint active) has a double
// root in λ there: Gauss-Newton halves λ each pass instead of converging quadratically, and a
// gripper at its limit still missed the tolerance after 8 passes. After each pass every slack
// is set from its constraint, λ = ±√max(g(x), 0): an inactive one stays exactly satisfied, and
// an active one (λ = 0) makes its row g(x) = 0 in the next linearisation, an equality that
// holds the boundary (FuseSequence's active-set test releases it when the data pull inside).
// x is not moved.
// The slack block of an inequality g(x) - λ² = 0 (a one-row constraint with one slack), or -1.
int SlackBlock(const Factor& f, const std::vector<Block>& blocks) {
  if (!f.is_constraint() || f.residual->dimension() != 1) return -1;
  int slack = -1;
  for (int b : f.blocks) {
    if (blocks[b].kind == BlockKind::kSlack) {
      if (slack >= 0) return -1;
      slack = b;
    }
  }
  return slack;
}

// Active-set tests per sequence (each one Gauss-Newton pass).
constexpr int kMaxReleases = 3;
// An inequality with g(x) within this many constraint tolerances of 0 is on its boundary.
constexpr double kBoundary = 100;

// Whether `state` moved from `previous` by at most a tenth of a standard deviation in every
// coordinate but the slacks (1e-10 absolute for one the constraints pin). Gauss-Newton's next
// step is of the order of this one squared: what is left is far below the noise.
bool StepSettled(const Values& previous, const GaussianState& state) {
  const Eigen::VectorXd step = LocalCoordinates(state.blocks, previous, state.mean);
  for (const Block& b : state.blocks) {
    if (b.kind == BlockKind::kSlack) continue;
    for (int i = b.tangent_offset; i < b.tangent_offset + TangentDim(b.kind); ++i) {
      const double sigma = std::sqrt(std::max(state.covariance(i, i), 0.0));
      if (std::abs(step[i]) > 0.1 * sigma + 1e-10) return false;
    }
  }
  return true;
}

// `boundary`: a g at or below it puts λ exactly at 0. A slack of 1e-5 left by roundoff on an
// active limit would make its row -2λ δλ + ∇g δx = 0 almost free of x, and the next pass would
// throw the joint as far past the limit as the data pull (an ANYmal hip 0.18 past, at 10 mm
// noise); at 0 the row holds the boundary until the active-set test releases it.
void ProjectSlacks(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                   double boundary, Values* values) {
  double g = 0;
  for (const Factor& f : factors) {
    const int slack = SlackBlock(f, blocks);
    if (slack < 0) continue;
    double& lambda = values->slacks[blocks[slack].index];
    const double sign = lambda < 0 ? -1 : 1;
    const double old = lambda;
    lambda = 0;
    EvaluateResidualAt(*f.residual, blocks, f.blocks, *values, nullptr, &g, nullptr);
    lambda = !std::isfinite(g) ? old : g <= boundary ? 0.0 : sign * std::sqrt(g);
  }
}

}  // namespace

SequenceSummary FuseSequence(const std::vector<Factor>& factors, GaussianState* state,
                             const SequenceOptions& options) {
  const GaussianState prior = *state;
  SequenceSummary summary;
  Values previous = prior.mean;
  // One Gauss-Newton pass from the prior, linearised about `at`, in the prior's chart until its
  // end (Fuse's `offset`); `skip` leaves factors out.
  auto gauss_newton_pass = [&](const Values& at, GaussianState* out, const std::vector<bool>* skip,
                               std::vector<FusionSummary>* fusions) {
    *out = prior;
    FusionOptions fusion = options.fusion;
    fusion.max_iterations = 1;
    Eigen::VectorXd offset = Eigen::VectorXd::Zero(out->dim());
    for (size_t i = 0; i < factors.size(); ++i) {
      if (skip && (*skip)[i]) continue;
      FusionSummary s = Fuse(factors[i], out, fusion, &at, &offset);
      if (fusions) fusions->push_back(s);
    }
    RetractOffset(out, &offset);
  };
  int passes_allowed = options.max_passes, releases = 0;
  const bool all_linear = std::all_of(factors.begin(), factors.end(),
                                      [](const Factor& f) { return f.residual->is_linear(); });
  for (int pass = 0; pass < passes_allowed; ++pass) {
    summary.fusions.clear();
    if (pass == 0 && !options.gauss_newton_from_start) {
      // The first pass fuses each factor with local iterations about the estimate so far.
      // Its covariance is discarded: the Gauss-Newton passes that follow start from the prior.
      FusionOptions first = options.fusion;
      first.covariance_at_final_iterate = false;
      for (const Factor& f : factors) summary.fusions.push_back(Fuse(f, state, first));
    } else {
      // Later passes linearise every factor once, about the previous estimate: the sequence
      // of linear updates is then one Gauss-Newton step of the whole problem.
      previous = state->mean;
      gauss_newton_pass(previous, state, nullptr, &summary.fusions);
    }
    summary.passes = pass + 1;
    ProjectSlacks(factors, state->blocks, kBoundary * options.constraint_tolerance, &state->mean);
    const double last_residual = summary.max_constraint_residual;
    summary.max_constraint_residual = MaxConstraintResidual(factors, state->blocks, state->mean);
    if (summary.max_constraint_residual > options.constraint_tolerance) {
      // Gauss-Newton converges only linearly where the data's residuals are large: about the
      // noise over the lever arms per pass (0.17 for 1 cm noise on markers 6 cm apart: a Z1
      // arm's constraints reached 1.3e-8 after 8 passes). While each pass at least halves
      // the residual, one more is allowed, up to 4 x max_passes; a sequence that is not
      // converging still stops at max_passes.
      if (pass + 1 == passes_allowed && pass > 0 &&
          summary.max_constraint_residual < 0.5 * last_residual &&
          passes_allowed < 4 * options.max_passes) {
        ++passes_allowed;
      }
      continue;
    }
    // Converged takes a Gauss-Newton pass whose step is negligible next to the estimate's
    // uncertainty, too: the constraints alone can hold while the estimate still moves (a slack
    // leaving its boundary absorbs every step of the joint it limits), and the first pass's
    // result depends on the order of its updates when the start is far off.
    // (One pass is exact when every factor is affine.)
    const bool gauss_newton = pass > 0 || options.gauss_newton_from_start;
    if (!all_linear && (!gauss_newton || !StepSettled(previous, *state))) continue;
    // Converged. An inequality held at its boundary (λ = 0) is an equality in the
    // linearisation and cannot leave the boundary by itself: the active-set test. One pass
    // without the active inequalities; those the data then put inside (g > 0) are released
    // and the passes go on from there.
    std::vector<bool> active(factors.size(), false);
    bool any_active = false;
    // At the boundary: g(x) = λ² within a hundred times the tolerance (a slack of 1e-6 is as
    // stuck as one of 0: its row barely moves it).
    for (size_t i = 0; i < factors.size(); ++i) {
      const int slack = SlackBlock(factors[i], state->blocks);
      if (slack < 0) continue;
      const double lambda = state->mean.slacks[state->blocks[slack].index];
      if (lambda * lambda <= kBoundary * options.constraint_tolerance)
        active[i] = any_active = true;
    }
    if (any_active && (releases < kMaxReleases || options.boundary_free_covariance)) {
      GaussianState free;
      gauss_newton_pass(state->mean, &free, &active, nullptr);
      bool released = false;
      double g = 0;
      for (size_t i = 0; i < factors.size() && releases < kMaxReleases; ++i) {
        if (!active[i]) continue;
        Values at = free.mean;
        at.slacks[state->blocks[SlackBlock(factors[i], state->blocks)].index] = 0;
        EvaluateResidualAt(*factors[i].residual, state->blocks, factors[i].blocks, at, nullptr, &g,
                           nullptr);
        released = released || g > options.constraint_tolerance;
      }
      if (released) {
        ++releases;
        *state = std::move(free);
        ProjectSlacks(factors, state->blocks, kBoundary * options.constraint_tolerance,
                      &state->mean);
        // The released state starts afresh, as far off as a new start can be (an arm whose
        // first pass pinned a joint on its limit, the data far inside): a full allowance.
        passes_allowed = std::max(passes_allowed, pass + 1 + options.max_passes);
        continue;
      }
      // The data pull beyond the boundary, and the estimate stays on it (options).
      if (options.boundary_free_covariance) state->covariance = std::move(free.covariance);
    }
    summary.converged = true;
    break;
  }
  return summary;
}

}  // namespace cfuse
