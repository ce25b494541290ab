// The batch problem of sparse_solver.h with the joints of a kinematic forest eliminated: each
// component's pose is its root's pose and the joint variables on its way up (forward
// kinematics, kinematic_forest.h), so every joint of the forest holds by construction, and
// Gauss-Newton runs on those few numbers and the constraint rows the forest does not hold (a
// loop's closing constraint, distances, parallels). An inequality's slack λ appears in its
// one row alone, so each is eliminated with that row: linearised, the row gives λ's step from
// the others', and λ's prior becomes one more measurement of them.
//
// It minimises the same objective as SolveSparse,
//   ½ δᵀ P0⁻¹ δ + ½ Σ_m r_m(x)ᵀ R_m⁻¹ r_m(x)      subject to  c_k(x) = 0,
// the prior on every component's pose in the chart at its prior mean, not on the joint
// variables (Lowe's parametric form, parametric.h, puts it on the parameters and so answers
// a different question): a joint's zero-variance constraint fused and the joint's own
// parametrisation are the same conditioning, so the answer is the filter's and the sparse
// solver's, at the cost of the parametric form (a few parameters instead of a pose and five
// constraint rows per link). Each iteration solves, with z the parameters and slacks and
// T = dx/dz,
//   [H  Cᵀ] [Δ]   [-g]       H = Tᵀ (D0ᵀ P0⁻¹ D0 + Jᵀ R⁻¹ J) T,  g = Tᵀ (D0ᵀ P0⁻¹ δ + Jᵀ R⁻¹ r),
//   [C  0 ] [μ] = [-c],      C = A T   (the slacks' terms through their rows, as above),
// densely, by H's Cholesky factor and the constraint rows' Schur complement; a row whose
// pivot vanishes against its variance (a combination of rows before it) is left out, as in the
// sparse solver. Dense in the parameters (their cube per iteration), but a pose's prior and
// measurements are gathered in its own tangent before they reach the parameters that move it.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/fit_analysis.h"
#include "cfuse/kernel/values.h"

namespace cfuse::internal {

struct ReducedOptions {
  int max_iterations = 100;
  // Converged, as SolveSparse, once every constraint row holds to `constraint_tolerance`
  // after a step of at most `settled_fraction` of each parameter's standard deviation, or
  // once no parameter moves by more than `step_tolerance`.
  double settled_fraction = 0.1;
  double step_tolerance = 1e-13;
  double constraint_tolerance = 1e-10;  // in the residuals' units
  double dependence_tolerance = 1e-12;
  // > 0: a converged answer's fit analysed too (AnalyseReducedFit at this extent), on the
  // solve's own forest and at its last forward kinematics.
  double fit_extent = 0;
  // A forest of more parameters is not solved (ReducedSummary::unsupported says so): the
  // dense steps cost their cube.
  int max_parameters = std::numeric_limits<int>::max();
};

struct ReducedSummary {
  // Why nothing was solved (ReducedUnsupported's answer, or more parameters than
  // ReducedOptions::max_parameters), or empty.
  std::string unsupported;
  bool converged = false;
  // false: a residual or a Jacobian not finite, or H not positive definite; no covariance.
  bool factorized = true;
  int iterations = 0;
  int parameters = 0;         // the forest's
  int eliminated_slacks = 0;  // slacks eliminated with their inequality's row
  int constraint_rows = 0;    // rows the forest does not hold, and not those
  int dependent_rows = 0;     // of those, left out as combinations of others (last iteration)
  double max_constraint_residual = 0;  // max |c_k(x)| over every constraint factor
};

struct ReducedEstimate {
  Values mean;
  // In the chart at `mean` (Block::tangent_offset): whole, or with `pairs` given to
  // SolveReduced, each block's own and those pairs' only, NaN elsewhere.
  Eigen::MatrixXd covariance;
  // With ReducedOptions::fit_extent: true and AnalyseReducedFit's answer at `mean` in
  // `analysis`, or false where it has none (the measurements leave directions free).
  bool analysed = false;
  FitAnalysis analysis;
};

// Empty when the graph's joints can be eliminated for these factors: every component rigid,
// a forest under ForestRules::kJointsFirst with at least one joint, the factors' blocks poses
// and slacks only, each slack in one one-row inequality; `parameters` (if given) then gets
// ReducedParameters. Else why not.
std::string ReducedUnsupported(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                               int* parameters = nullptr);

// The parameters `SolveReduced` would work on: root poses and joint variables (0 when
// unsupported).
int ReducedParameters(const ConstraintGraph& graph);

// Solves from the prior N(prior_mean, diag(prior_variance)) over graph.blocks, starting at
// `initial` (read into root poses and joint variables as the parametric form reads a start)
// or at the prior mean. `factors` as Solve builds them: measurements and the graph's
// constraints (those the forest holds are recognised by their residual and skipped).
// `pairs`, if given: the covariance of each block and of these pairs of blocks only (what
// results report of a large model), not the whole. A graph or factors it does not take
// (ReducedUnsupported) are answered by `unsupported`, `estimate` untouched: the question is
// settled by the same preparation the solve needs.
ReducedSummary SolveReduced(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                            const Values& prior_mean, const Eigen::VectorXd& prior_variance,
                            ReducedEstimate* estimate, const ReducedOptions& options = {},
                            const Values* initial = nullptr,
                            const std::vector<std::pair<int, int>>* pairs = nullptr);

// AnalyseFit (cfuse/kernel/fit_analysis.h) of an answer whose joints hold, counted on the
// forest's parameters: the joints' own rows are held by the parametrisation and each
// inequality's row by its slack (away from its boundary, as SolveReduced's answers that solve
// keeps are), so the degrees of freedom are the parameters' less the rank of
// the other constraint rows, and those the measurements determine are counted among them, as
// AnalyseFit's dense analysis counts them on the whole state (radians against the extent).
// The same fit and counts at a fraction of the cost. False, `out` untouched, when the
// measurements leave directions free (AnalyseFit names them in the whole state) or when the
// graph's joints cannot be eliminated.
bool AnalyseReducedFit(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                       const Values& values, double extent, FitAnalysis* out);

}  // namespace cfuse::internal
