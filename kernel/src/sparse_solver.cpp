#include "cfuse/kernel/sparse_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/so3.h"
#include "sparse_ldlt.h"

namespace cfuse {
namespace {

using Triplet = Eigen::Triplet<double>;

// Nodes in approximate-minimum-degree order, from the pairs of nodes that share a row.
std::vector<int> MinimumDegreeOrder(int nodes, const std::vector<std::pair<int, int>>& edges) {
  std::vector<int> order(nodes);
  if (nodes == 0) return order;
  std::vector<Triplet> t;
  t.reserve(nodes + 2 * edges.size());
  for (int i = 0; i < nodes; ++i) t.emplace_back(i, i, 1.0);
  for (const auto& [a, b] : edges) {
    t.emplace_back(a, b, 1.0);
    t.emplace_back(b, a, 1.0);
  }
  Eigen::SparseMatrix<double> pattern(nodes, nodes);
  pattern.setFromTriplets(t.begin(), t.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> p;
  Eigen::AMDOrdering<int>()(pattern, p);
  // AMD gives, for each place in the order, the node eliminated there (SimplicialLDLT inverts it
  // to permute its matrix).
  for (int k = 0; k < nodes; ++k) order[k] = p.indices()[k];
  return order;
}

// Where each state coordinate and each constraint row sits in the KKT matrix: every state
// coordinate first (blocks kept whole, in minimum-degree order of the blocks that measurements
// join), then every constraint row (factors kept whole, in minimum-degree order of the
// constraints that share a block).
struct Layout {
  int n = 0;                           // state coordinates
  int m = 0;                           // constraint rows
  std::vector<int> coordinate;         // state coordinate -> position
  std::vector<int> first_row;          // factor -> position of its first row (constraints)
  std::vector<std::vector<int>> cols;  // factor -> state coordinate of each Jacobian column
  std::vector<std::vector<int>> constraints_of_block;  // block -> constraint factors on it
  bool measurements_within_blocks = true;              // no measurement joins two blocks
  // measurement factor -> Lw⁻¹, R = Lw Lwᵀ its noise (NaN where R is not positive definite,
  // which then fails the factorisation); computed once, the noise does not change.
  std::vector<Eigen::MatrixXd> whiten;
};

Layout MakeLayout(const std::vector<Factor>& factors, const std::vector<Block>& blocks, int n) {
  Layout layout;
  layout.n = n;
  const int num_blocks = static_cast<int>(blocks.size());
  layout.cols.resize(factors.size());
  std::vector<std::pair<int, int>> block_edges;
  std::vector<int> constraints;
  std::vector<std::vector<int>> constraints_of_block(num_blocks);
  layout.constraints_of_block.resize(num_blocks);
  for (size_t f = 0; f < factors.size(); ++f) {
    for (int b : factors[f].blocks) {
      for (int i = 0; i < TangentDim(blocks[b].kind); ++i) {
        layout.cols[f].push_back(blocks[b].tangent_offset + i);
      }
    }
    if (factors[f].is_constraint()) {
      for (int b : factors[f].blocks) {
        constraints_of_block[b].push_back(static_cast<int>(constraints.size()));
        layout.constraints_of_block[b].push_back(static_cast<int>(f));
      }
      constraints.push_back(static_cast<int>(f));
      layout.m += factors[f].residual->dimension();
    } else {
      const Eigen::LLT<Eigen::MatrixXd> llt(factors[f].noise);
      const Eigen::Index rows = factors[f].noise.rows();
      layout.whiten.resize(factors.size());
      layout.whiten[f] =
          llt.info() == Eigen::Success
              ? Eigen::MatrixXd(llt.matrixL().solve(Eigen::MatrixXd::Identity(rows, rows)))
              : Eigen::MatrixXd::Constant(rows, rows, NAN);
      for (size_t s = 1; s < factors[f].blocks.size(); ++s) {
        block_edges.emplace_back(factors[f].blocks[0], factors[f].blocks[s]);
        layout.measurements_within_blocks = false;
      }
    }
  }
  layout.coordinate.assign(n, -1);
  int position = 0;
  for (int b : MinimumDegreeOrder(num_blocks, block_edges)) {
    for (int i = 0; i < TangentDim(blocks[b].kind); ++i) {
      layout.coordinate[blocks[b].tangent_offset + i] = position++;
    }
  }
  CFUSE_CHECK_EQ(position, n);
  std::vector<std::pair<int, int>> constraint_edges;
  for (const std::vector<int>& list : constraints_of_block) {
    for (size_t i = 1; i < list.size(); ++i) {
      for (size_t j = 0; j < i; ++j) constraint_edges.emplace_back(list[i], list[j]);
    }
  }
  layout.first_row.assign(factors.size(), -1);
  for (int c : MinimumDegreeOrder(static_cast<int>(constraints.size()), constraint_edges)) {
    layout.first_row[constraints[c]] = position;
    position += factors[constraints[c]].residual->dimension();
  }
  return layout;
}

// K's upper triangle (positions of Layout) at one linearisation, the right-hand side, and each
// constraint row's threshold for dependence; with cross-covariances asked for, also what they
// are computed from (CrossCovariance).
struct KktSystem {
  std::vector<Triplet> entries;  // in the same order at every linearisation
  std::vector<int> slot;         // entry -> its place among K's stored values
  Eigen::VectorXd rhs;
  Eigen::VectorXd drop_below;
  std::vector<Eigen::MatrixXd> information;  // per block: its diagonal block of Λ
  std::vector<Eigen::MatrixXd> jacobian;     // per factor: A's rows (constraints only)
};

void Add(std::vector<Triplet>* t, int i, int j, double v) {
  t->emplace_back(std::min(i, j), std::max(i, j), v);
}

// Where each entry landed among the stored values of `upper` (set from `entries`, duplicates
// summed, explicit zeros kept).
std::vector<int> Slots(const Eigen::SparseMatrix<double>& upper,
                       const std::vector<Triplet>& entries) {
  std::vector<int> slot(entries.size());
  const int* inner = upper.innerIndexPtr();
  const int* outer = upper.outerIndexPtr();
  for (size_t e = 0; e < entries.size(); ++e) {
    const int* first = inner + outer[entries[e].col()];
    const int* last = inner + outer[entries[e].col() + 1];
    const int* it = std::lower_bound(first, last, entries[e].row());
    CFUSE_CHECK(it != last && *it == entries[e].row());
    slot[e] = static_cast<int>(it - inner);
  }
  return slot;
}

// `room`: explicit zeros that make room in the factor for the cross-covariances asked for;
// `for_pairs`: keep what CrossCovariance reads.
void Assemble(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
              const Values& mean, const Eigen::VectorXd& prior_variance,
              const std::vector<Triplet>& room, bool for_pairs, const Layout& layout,
              const Eigen::VectorXd& delta, const SparseOptions& options, KktSystem* kkt) {
  const int size = layout.n + layout.m;
  kkt->entries.clear();
  kkt->rhs = Eigen::VectorXd::Zero(size);
  kkt->drop_below = Eigen::VectorXd::Constant(size, -1.0);
  if (for_pairs) {
    kkt->jacobian.resize(factors.size());
    kkt->information.resize(blocks.size());
    for (size_t b = 0; b < blocks.size(); ++b) {
      kkt->information[b] =
          prior_variance.segment(blocks[b].tangent_offset, TangentDim(blocks[b].kind))
              .cwiseInverse()
              .asDiagonal();
    }
  }
  for (int i = 0; i < layout.n; ++i) {
    Add(&kkt->entries, layout.coordinate[i], layout.coordinate[i], 1 / prior_variance[i]);
  }
  // Each block's own covariance whole, measured or not.
  for (const Block& b : blocks) {
    for (int i = 0; i < TangentDim(b.kind); ++i) {
      for (int j = 0; j < i; ++j) {
        Add(&kkt->entries, layout.coordinate[b.tangent_offset + i],
            layout.coordinate[b.tangent_offset + j], 0.0);
      }
    }
  }
  kkt->entries.insert(kkt->entries.end(), room.begin(), room.end());
  Eigen::VectorXd r, J_delta, ew, g;
  Eigen::MatrixXd J, Jw, information;
  for (size_t f = 0; f < factors.size(); ++f) {
    const Factor& factor = factors[f];
    EvaluateResidual(*factor.residual, blocks, factor.blocks, mean, &r, &J, &delta);
    const std::vector<int>& cols = layout.cols[f];
    J_delta = -r;
    for (size_t c = 0; c < cols.size(); ++c) J_delta += J.col(c) * delta[cols[c]];
    if (factor.is_constraint()) {
      if (for_pairs) kkt->jacobian[f] = J;
      for (int row = 0; row < J.rows(); ++row) {
        const int p = layout.first_row[f] + row;
        kkt->rhs[p] = J_delta[row];
        double prior = 0;
        for (size_t c = 0; c < cols.size(); ++c) {
          Add(&kkt->entries, p, layout.coordinate[cols[c]], J(row, c));
          prior += J(row, c) * J(row, c) * prior_variance[cols[c]];
        }
        kkt->drop_below[p] = options.dependence_tolerance * prior;
      }
      continue;
    }
    // Whitened: Jᵀ R⁻¹ J = Jwᵀ Jw and Jᵀ R⁻¹ (J δ - r) = Jwᵀ (Lw⁻¹ (J δ - r)), R = Lw Lwᵀ.
    const Eigen::MatrixXd& whiten = layout.whiten[f];
    Jw.noalias() = whiten * J;
    ew.noalias() = whiten * J_delta;
    information.noalias() = Jw.transpose() * Jw;
    g.noalias() = Jw.transpose() * ew;
    if (for_pairs && factor.blocks.size() == 1) {
      kkt->information[factor.blocks[0]] += information;
    }
    for (size_t c = 0; c < cols.size(); ++c) {
      kkt->rhs[layout.coordinate[cols[c]]] += g[c];
      for (size_t c2 = 0; c2 <= c; ++c2) {
        Add(&kkt->entries, layout.coordinate[cols[c]], layout.coordinate[cols[c2]],
            information(c, c2));
      }
    }
  }
}

// Cross-covariances. With Λ block-diagonal (every measurement on one block), for blocks a ≠ b
//   Cov(a, b) = -(Λ⁻¹ Aᵀ S⁻¹ A Λ⁻¹)_ab = Λ_a⁻¹ A_{r,a}ᵀ Z_rs A_{s,b} Λ_b⁻¹,
// summed over the constraint rows r on a and s on b, Z_rs = -(S⁻¹)_rs the KKT inverse's
// constraint part. Z_rs is on the factor's pattern once K holds an explicit zero at (r, s):
// for a tree of joints that joins the constraints of neighbouring links, and the factor stays
// linear in the tree's size. Where a measurement joins blocks, Λ⁻¹ is not block-diagonal, and
// the explicit zeros go between the two blocks' coordinates instead, read off directly.
std::vector<Triplet> RoomForPairs(const std::vector<std::pair<int, int>>& pairs,
                                  const std::vector<Factor>& factors,
                                  const std::vector<Block>& blocks, const Layout& layout) {
  std::vector<Triplet> room;
  auto rows = [&](int block) {
    std::vector<int> out;
    for (int f : layout.constraints_of_block[block]) {
      for (int i = 0; i < factors[f].residual->dimension(); ++i)
        out.push_back(layout.first_row[f] + i);
    }
    return out;
  };
  for (const auto& [a, b] : pairs) {
    if (!layout.measurements_within_blocks) {
      for (int i = 0; i < TangentDim(blocks[a].kind); ++i) {
        for (int j = 0; j < TangentDim(blocks[b].kind); ++j) {
          Add(&room, layout.coordinate[blocks[a].tangent_offset + i],
              layout.coordinate[blocks[b].tangent_offset + j], 0.0);
        }
      }
      continue;
    }
    const std::vector<int> rows_a = rows(a), rows_b = rows(b);
    for (int r : rows_a) {
      for (int s : rows_b) {
        if (r != s) Add(&room, r, s, 0.0);
      }
    }
  }
  return room;
}

// Cov(a, b), a ≠ b, in the prior's chart, from the selected inverse (see RoomForPairs).
Eigen::MatrixXd CrossCovariance(int a, int b, const std::vector<Block>& blocks,
                                const Layout& layout, const KktSystem& kkt,
                                const internal::SparseLdlt& ldlt) {
  const int da = TangentDim(blocks[a].kind), db = TangentDim(blocks[b].kind);
  const int oa = blocks[a].tangent_offset, ob = blocks[b].tangent_offset;
  Eigen::MatrixXd P(da, db);
  if (!layout.measurements_within_blocks) {
    for (int i = 0; i < da; ++i) {
      for (int j = 0; j < db; ++j) {
        P(i, j) = ldlt.Inverse(layout.coordinate[oa + i], layout.coordinate[ob + j]);
      }
    }
    return P;
  }
  // The rows of A on a block: their positions, and their columns on the block.
  auto rows = [&](int block, int offset, int dim, std::vector<int>* positions) {
    int count = 0;
    for (int f : layout.constraints_of_block[block]) count += kkt.jacobian[f].rows();
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(count, dim);
    int k = 0;
    for (int f : layout.constraints_of_block[block]) {
      const Eigen::MatrixXd& J = kkt.jacobian[f];
      const std::vector<int>& cols = layout.cols[f];
      for (int i = 0; i < J.rows(); ++i, ++k) {
        for (size_t c = 0; c < cols.size(); ++c) {
          if (cols[c] >= offset && cols[c] < offset + dim) A(k, cols[c] - offset) += J(i, c);
        }
        positions->push_back(layout.first_row[f] + i);
      }
    }
    return A;
  };
  std::vector<int> ra, rb;
  const Eigen::MatrixXd A_a = rows(a, oa, da, &ra), A_b = rows(b, ob, db, &rb);
  Eigen::MatrixXd Z(ra.size(), rb.size());
  for (size_t i = 0; i < ra.size(); ++i) {
    for (size_t j = 0; j < rb.size(); ++j) Z(i, j) = ldlt.Inverse(ra[i], rb[j]);
  }
  P.noalias() = A_a.transpose() * Z * A_b;
  const Eigen::LLT<Eigen::MatrixXd> La(kkt.information[a]), Lb(kkt.information[b]);
  return La.solve(Lb.solve(P.transpose()).transpose());
}

// Whether every constraint holds to the tolerance at prior_mean ⊞ delta, after a step within
// the settled fraction of each coordinate's standard deviation (slacks aside; 1e-10 absolute
// where the constraints pin a coordinate), the deviations those of this factorisation.
bool Settled(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
             const Values& prior_mean, const Layout& layout, const Eigen::VectorXd& step,
             const Eigen::VectorXd& delta, const SparseOptions& options,
             internal::SparseLdlt* ldlt) {
  Eigen::VectorXd r;
  for (const Factor& f : factors) {
    if (!f.is_constraint()) continue;
    EvaluateResidual(*f.residual, blocks, f.blocks, prior_mean, &r, nullptr, &delta);
    if (!(r.lpNorm<Eigen::Infinity>() <= options.constraint_tolerance)) return false;
  }
  ldlt->ComputeSelectedInverse();
  for (const Block& b : blocks) {
    if (b.kind == BlockKind::kSlack) continue;
    for (int i = b.tangent_offset; i < b.tangent_offset + TangentDim(b.kind); ++i) {
      const int p = layout.coordinate[i];
      const double sigma = std::sqrt(std::max(ldlt->Inverse(p, p), 0.0));
      if (std::abs(step[i]) > options.settled_fraction * sigma + 1e-10) return false;
    }
  }
  return true;
}

// The chart at the solution for a block, as SolveBatch and the filter use: G = Jr(δθ) on a
// pose's rotation, the identity elsewhere.
Eigen::MatrixXd ChartAtSolution(const Block& b, const Eigen::VectorXd& delta) {
  const int dim = TangentDim(b.kind);
  Eigen::MatrixXd G = Eigen::MatrixXd::Identity(dim, dim);
  if (b.kind == BlockKind::kPose) {
    G.topLeftCorner<3, 3>() = RightJacobianSO3(delta.segment<3>(b.tangent_offset));
  }
  return G;
}

}  // namespace

Eigen::MatrixXd SparseEstimate::Covariance(int a, int b) const {
  if (full_.size() > 0) {
    CFUSE_CHECK(a >= 0 && b >= 0 && a < static_cast<int>(blocks.size()) &&
                b < static_cast<int>(blocks.size()));
    return full_.block(blocks[a].tangent_offset, blocks[b].tangent_offset,
                       TangentDim(blocks[a].kind), TangentDim(blocks[b].kind));
  }
  if (a == b) {
    CFUSE_CHECK(a >= 0 && a < static_cast<int>(own_.size()));
    return own_[a];
  }
  const auto it = pairs_.find({std::min(a, b), std::max(a, b)});
  CFUSE_CHECK_MSG(it != pairs_.end(), "a cross-covariance that was not asked for");
  return a < b ? it->second : Eigen::MatrixXd(it->second.transpose());
}

bool SparseEstimate::HasCovariance(int a, int b) const {
  return a == b || full_.size() > 0 || pairs_.count({std::min(a, b), std::max(a, b)}) > 0;
}

SparseSummary SolveSparse(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                          const Values& prior_mean, const Eigen::VectorXd& prior_variance,
                          const std::vector<std::pair<int, int>>& covariance_pairs,
                          SparseEstimate* estimate, const SparseOptions& options,
                          const Values* initial) {
  const int n = static_cast<int>(prior_variance.size());
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [a, b] : covariance_pairs) {
    CFUSE_CHECK(a >= 0 && b >= 0 && a < static_cast<int>(blocks.size()) &&
                b < static_cast<int>(blocks.size()));
    if (a != b) pairs.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());

  const Layout layout = MakeLayout(factors, blocks, n);
  const int size = layout.n + layout.m;
  Eigen::VectorXd delta =
      initial ? LocalCoordinates(blocks, prior_mean, *initial) : Eigen::VectorXd::Zero(n);
  KktSystem kkt;
  Eigen::SparseMatrix<double> upper(size, size);
  internal::SparseLdlt ldlt;
  SparseSummary summary;
  Eigen::VectorXd x(size);
  const std::vector<Triplet> room = RoomForPairs(pairs, factors, blocks, layout);
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    Assemble(factors, blocks, prior_mean, prior_variance, room, !pairs.empty(), layout, delta,
             options, &kkt);
    if (iteration == 0) {
      upper.setFromTriplets(kkt.entries.begin(), kkt.entries.end());
      ldlt.Analyze(upper);
      kkt.slot = Slots(upper, kkt.entries);
    } else {
      // The same entries as at the first linearisation: only their values change.
      double* values = upper.valuePtr();
      std::fill(values, values + upper.nonZeros(), 0.0);
      for (size_t e = 0; e < kkt.entries.size(); ++e) values[kkt.slot[e]] += kkt.entries[e].value();
    }
    if (!kkt.rhs.allFinite() || !ldlt.Factorize(upper, kkt.drop_below)) {
      summary.factorized = false;
      break;
    }
    x = kkt.rhs;
    ldlt.Solve(&x);
    Eigen::VectorXd next(n);
    for (int i = 0; i < n; ++i) next[i] = x[layout.coordinate[i]];
    const Eigen::VectorXd step = next - delta;
    delta = next;
    summary.iterations = iteration + 1;
    if (step.lpNorm<Eigen::Infinity>() <=
            options.step_tolerance * (1 + delta.lpNorm<Eigen::Infinity>()) ||
        (options.settled_fraction > 0 &&
         Settled(factors, blocks, prior_mean, layout, step, delta, options, &ldlt))) {
      summary.converged = true;
      break;
    }
  }
  if (summary.factorized) summary.dependent_rows = ldlt.dropped();
  summary.factor_nonzeros = ldlt.nonzeros();

  estimate->blocks = blocks;
  estimate->mean = prior_mean;
  Retract(blocks, delta, &estimate->mean);
  estimate->own_.assign(blocks.size(), Eigen::MatrixXd());
  estimate->pairs_.clear();
  estimate->full_.resize(0, 0);
  if (summary.factorized && options.full_covariance) {
    const Eigen::MatrixXd by_position = ldlt.InverseLeading(n);
    Eigen::MatrixXd& P = estimate->full_;
    P.resize(n, n);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) P(i, j) = by_position(layout.coordinate[i], layout.coordinate[j]);
    }
    // To the chart at the solution: P <- G P Gᵀ, G block-diagonal.
    for (const Block& b : blocks) {
      if (b.kind != BlockKind::kPose) continue;
      const Eigen::MatrixXd G = ChartAtSolution(b, delta);
      const int dim = TangentDim(b.kind);
      P.middleRows(b.tangent_offset, dim) = G * P.middleRows(b.tangent_offset, dim);
      P.middleCols(b.tangent_offset, dim) = P.middleCols(b.tangent_offset, dim) * G.transpose();
    }
  } else if (summary.factorized) {
    if (!ldlt.has_selected_inverse()) ldlt.ComputeSelectedInverse();
    auto chart = [&](int b) { return ChartAtSolution(blocks[b], delta); };
    for (size_t b = 0; b < blocks.size(); ++b) {
      const int o = layout.coordinate[blocks[b].tangent_offset], dim = TangentDim(blocks[b].kind);
      Eigen::MatrixXd P(dim, dim);
      for (int i = 0; i < dim; ++i) {
        for (int j = 0; j <= i; ++j) P(i, j) = P(j, i) = ldlt.Inverse(o + i, o + j);
      }
      estimate->own_[b] = chart(static_cast<int>(b)) * P * chart(static_cast<int>(b)).transpose();
    }
    for (const auto& [a, b] : pairs) {
      estimate->pairs_[{a, b}] =
          chart(a) * CrossCovariance(a, b, blocks, layout, kkt, ldlt) * chart(b).transpose();
    }
  }
  Eigen::VectorXd r;
  for (const Factor& f : factors) {
    if (!f.is_constraint()) continue;
    EvaluateResidual(*f.residual, blocks, f.blocks, estimate->mean, &r, nullptr);
    summary.max_constraint_residual =
        std::max(summary.max_constraint_residual, r.lpNorm<Eigen::Infinity>());
  }
  return summary;
}

}  // namespace cfuse
