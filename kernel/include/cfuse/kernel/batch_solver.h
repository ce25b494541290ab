// The batch reference solver: equality-constrained Gauss-Newton over all factors at once,
// used to validate the incremental filter (estimator.h), which must agree with it.
//
// With x = x0 ⊞ δ in the prior's chart it minimises
//   ½ δᵀ P0⁻¹ δ + ½ Σ_m r_m(x)ᵀ R_m⁻¹ r_m(x)      subject to  c_k(x) = 0 for every constraint.
// Each iteration solves the linearised KKT system
//   [Λ  Aᵀ] [δ]   [Jᵀ R⁻¹ (J δ_i - r_i)]
//   [A  0 ] [μ] = [A δ_i - c_i         ],   Λ = P0⁻¹ + Jᵀ R⁻¹ J,
// by the null-space method (SVD of A), so redundant constraint rows need no special case; a
// contradiction leaves a constraint residual that is reported. The covariance is the inverse of
// Λ restricted to the constraint surface's tangent: Z (Zᵀ Λ Z)⁻¹ Zᵀ, Z a basis of null(A),
// moved to the chart at the solution like the filter's.
#pragma once

#include <vector>

#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/factor.h"

namespace cfuse {

struct BatchOptions {
  int max_iterations = 100;
  double step_tolerance = 1e-13;  // on max |δ_{i+1} - δ_i|, relative to 1 + max |δ|
  double rank_tolerance = 1e-10;  // singular values of A below it (relative) are zero
};

struct BatchSummary {
  bool converged = false;
  int iterations = 0;
  double max_constraint_residual = 0;  // max |c_k(x)| at the solution
};

// `state` holds the prior on entry (mean and covariance) and the solution on return. The
// Gauss-Newton iterations start at `initial` if given, else at the prior mean.
BatchSummary SolveBatch(const std::vector<Factor>& factors, GaussianState* state,
                        const BatchOptions& options = {}, const Values* initial = nullptr);

}  // namespace cfuse
