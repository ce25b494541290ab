// The batch problem of batch_solver.h solved by a sparse factorisation whose cost follows the
// constraint graph, not the square of the state; covariance blocks computed for the blocks and
// pairs of blocks a result reports, not for every pair.
//
// With x = x0 ⊞ δ in the prior's chart it minimises
//   ½ δᵀ P0⁻¹ δ + ½ Σ_m r_m(x)ᵀ R_m⁻¹ r_m(x)      subject to  c_k(x) = 0 for every constraint,
// P0 diagonal (independent blocks, as MakePrior's). Each Gauss-Newton iteration solves the
// linearised KKT system
//   [Λ  Aᵀ] [δ]   [Jᵀ R⁻¹ (J δ_i - r_i)]
//   [A  0 ] [μ] = [A δ_i - c_i         ],   Λ = P0⁻¹ + Jᵀ R⁻¹ J,
// by a sparse LDLᵀ factorisation in which every state coordinate is eliminated before any
// constraint row: the state's pivots are those of Λ (positive definite), the constraint rows'
// those of -A Λ⁻¹ Aᵀ (negative semidefinite), so no pivoting is needed. Within each part the
// order is approximate minimum degree: a chain of points, or a tree of joints with markers on
// its links, factors in time and memory linear in its size.
//
// A constraint row whose pivot vanishes (|d| at most 1e-12 of its variance under the prior
// alone, the filter's degeneracy test in estimator.h) is a combination of the rows before it
// and is left out (multiplier 0): redundant constraints need no special case. A contradiction
// shows as a constraint residual left at the end, as with SolveBatch.
//
// The covariance on the constraint surface is the state part of the KKT matrix's inverse. It is
// computed by selected inversion of the factor (Takahashi's recurrences), on the factor's
// pattern only: every block's own covariance and those of the pairs asked for, each moved to
// the chart at the solution like the filter's.
#pragma once

#include <Eigen/Core>
#include <map>
#include <utility>
#include <vector>

#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

struct SparseOptions {
  int max_iterations = 100;
  double step_tolerance = 1e-13;  // on max |δ_{i+1} - δ_i|, relative to 1 + max |δ|
  // Converged also, as FuseSequence (estimator.h), once every constraint holds to
  // `constraint_tolerance` after a step of at most `settled_fraction` of each coordinate's
  // standard deviation (slacks aside): the next step is of the order of this one squared, far
  // below the noise. 0 leaves only the step tolerance (the reference's criterion).
  double settled_fraction = 0.1;
  double constraint_tolerance = 1e-10;  // in the residuals' units
  // A constraint row whose pivot is at most this fraction of its variance under the prior is
  // a combination of others.
  double dependence_tolerance = 1e-12;
  // The covariance of every pair of blocks, by one solve with the factor per state coordinate
  // (O(n · entries of the factor)): for small states, where that costs less than the solve.
  bool full_covariance = false;
};

struct SparseSummary {
  bool converged = false;
  // false: a residual, a Jacobian or a pivot was not finite, or Λ not positive definite; the
  // mean is then the last iterate's and there is no covariance.
  bool factorized = true;
  int iterations = 0;
  int dependent_rows = 0;              // constraint rows left out as combinations of others
  double max_constraint_residual = 0;  // max |c_k(x)| at the solution
  long factor_nonzeros = 0;            // entries of L, for the cost's record
};

// The solution: the mean, and the covariance blocks that were asked for.
class SparseEstimate {
 public:
  std::vector<Block> blocks;
  Values mean;

  // Cov(block a, block b) (rows a's tangent, columns b's), in the chart at `mean`. Available
  // for a == b and for the pairs given to SolveSparse (either order), or for every pair with
  // SparseOptions::full_covariance; InternalError otherwise. Empty after a factorisation that
  // failed (SparseSummary::factorized).
  Eigen::MatrixXd Covariance(int a, int b) const;
  bool HasCovariance(int a, int b) const;
  // With SparseOptions::full_covariance: the whole covariance (laid out by
  // Block::tangent_offset), in the chart at `mean`; empty otherwise.
  const Eigen::MatrixXd& full_covariance() const { return full_; }

 private:
  friend SparseSummary SolveSparse(const std::vector<Factor>&, const std::vector<Block>&,
                                   const Values&, const Eigen::VectorXd&,
                                   const std::vector<std::pair<int, int>>&, SparseEstimate*,
                                   const SparseOptions&, const Values*);
  std::vector<Eigen::MatrixXd> own_;                      // per block
  std::map<std::pair<int, int>, Eigen::MatrixXd> pairs_;  // (a, b), a < b
  Eigen::MatrixXd full_;
};

// Solves from the prior N(prior_mean, diag(prior_variance)) over `blocks` (the variances laid
// out by Block::tangent_offset, e.g. PriorVariance() of estimator.h). `covariance_pairs` are
// the pairs of distinct blocks whose cross-covariance the caller will read. The iterations
// start at `initial` if given, else at the prior mean.
SparseSummary SolveSparse(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                          const Values& prior_mean, const Eigen::VectorXd& prior_variance,
                          const std::vector<std::pair<int, int>>& covariance_pairs,
                          SparseEstimate* estimate, const SparseOptions& options = {},
                          const Values* initial = nullptr);

}  // namespace cfuse
