// Incremental constraint fusion (Hel-Or & Werman 1994, §4-§5.1): a Gaussian estimate of every
// block, into which measurements and constraints are fused one at a time by the iterated
// extended Kalman filter. A constraint is a measurement with zero noise, so after its update
// the estimate satisfies it exactly (to the iteration tolerance) and its directions carry no
// variance.
//
// State and charts. The estimate is a mean (Values) and a covariance over the tangent
// coordinates of values.h's chart at that mean (an error state, as in an error-state Kalman
// filter). One update, for a factor r(x) with noise R (R = 0 for a constraint):
//   iterate   δ_{i+1} = K_i (H_i δ_i - r(x0 ⊞ δ_i)),   K_i = P0 H_iᵀ S_i⁻¹,
//             S_i = H_i P0 H_iᵀ + R,   H_i = ∂r/∂δ at δ_i (in the chart of x0)
//   until the step is below tolerance (the local iterations of §5.1, i.e. Gauss-Newton on the
//   prior plus this factor), then
//   mean      x1 = x0 ⊞ δ*,
//   covariance the Joseph form P1 = (I - K H) P0 (I - K H)ᵀ + K R Kᵀ with H at the final
//              iterate (P0 - K H P0 for the exact optimal gain; the Joseph form stays positive
//              semidefinite when roundoff makes the gain inexact),
//   reset     P1 <- G P1 Gᵀ, G = Jr(δθ*) on every rotation block, I elsewhere, which moves the
//             covariance from the chart at x0 to the chart at x1.
//
// Cost. Only the rows and columns of the blocks correlated with the factor's blocks change
// (correlation_groups.h); the covariance is updated there by a symmetric rank-k product, k the
// number of fused rows, and stays exactly symmetric. No allocation happens per update once
// the scratch buffers have grown.
//
// Degenerate directions. A direction u of the factor whose variance uᵀ S u is negligible next
// to its variance under the initial prior (uᵀ S_init u, S_init = H P_init Hᵀ) is already
// determined by constraints fused before: it is not inverted. The directions are the
// eigenvectors of S = U Λ Uᵀ, or, where the rows are nearly dependent, the generalised
// eigenvectors of (S, S_init) on the rows' range (rows that are numerically combinations of
// others have no direction of their own). If the factor's innovation along a determined
// direction (or a dependent combination of rows) is zero the rows are redundant and skipped;
// if not, the factor contradicts what was fused before, and the update is refused with status
// kContradiction.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "cfuse/kernel/correlation_groups.h"
#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

struct GaussianState {
  std::vector<Block> blocks;
  Values mean;
  Eigen::MatrixXd covariance;      // tangent_dim x tangent_dim
  Eigen::VectorXd prior_variance;  // the diagonal of the initial prior, for degeneracy tests
  // Blocks whose cross-covariances may be nonzero; updates touch only the groups their factor
  // reaches. A state whose groups do not cover its blocks is treated as fully correlated.
  CorrelationGroups groups;

  int dim() const { return static_cast<int>(covariance.rows()); }
};

// A vague prior: independent, centred on `mean`, with these standard deviations.
struct PriorScale {
  double position = 10.0;  // metres: points and translations
  double rotation = 1.0;   // radians
  double slack = 10.0;     // slack units
};
GaussianState MakePrior(const std::vector<Block>& blocks, const Values& mean,
                        const PriorScale& scale);
// That prior's variances, laid out by Block::tangent_offset (its covariance is their diagonal).
Eigen::VectorXd PriorVariance(const std::vector<Block>& blocks, const PriorScale& scale);

struct FusionOptions {
  int max_iterations = 50;
  double step_tolerance = 1e-10;          // on max |δ_{i+1} - δ_i|, relative to 1 + max |δ|
  double residual_tolerance = 1e-9;       // a constraint's max |r| at which its iterations stop
  double degeneracy_tolerance = 1e-12;    // uᵀ S u / uᵀ S_init u below it: already determined
  double contradiction_tolerance = 1e-7;  // |uᵀ r| / sqrt(uᵀ S_init u) above it: contradiction
  // The covariance from the Jacobian at the final iterate (one more evaluation when the
  // iterations moved): off only where it is discarded anyway (FuseSequence's first pass).
  bool covariance_at_final_iterate = true;
};

struct FusionSummary {
  enum class Status {
    kFused,            // every row fused
    kPartlyRedundant,  // some rows were already determined (and consistent); the rest fused
    kRedundant,        // every row was already determined and consistent: nothing changed
    kContradiction,    // a determined direction disagrees: nothing changed
    kNotConverged,     // the local iterations did not converge: the last iterate was applied
    kInvalid,          // the residual or its Jacobian was not finite: nothing changed
  };
  Status status = Status::kFused;
  int rows = 0;
  int rows_fused = 0;
  int iterations = 0;
  double innovation_nis = 0;  // r0ᵀ S⁻¹ r0 at the prior, over the fused directions
  // The same at the last linearisation, about the final iterate: the minimum of the factor's
  // linearised cost there, which at convergence is its exact (MAP) cost
  // ‖x - x0‖²_P⁻¹ + ‖r(x)‖²_R⁻¹. Equal to innovation_nis for an affine residual; for a curved
  // one (a point on a turning part) it does not count the linearisation error at the prior.
  double final_nis = 0;
  double contradiction = 0;  // the largest normalised innovation along a determined direction
  // kInvalid: the first residual row that was not finite, or whose Jacobian row was not (-1 for
  // a whitening that failed), so that a caller stacking many measurements can name the one.
  int invalid_row = -1;

  bool changed_state() const {
    return status == Status::kFused || status == Status::kPartlyRedundant ||
           status == Status::kNotConverged;
  }
};
const char* StatusName(FusionSummary::Status status);

// Fuses one factor. The local iterations start at `linearize_at` if given (a later pass of a
// sequential filter relinearises each factor about the previous pass's estimate), else at
// the state's mean.
//
// With `offset` (the state's tangent dimension), the estimate is state.mean ⊞ offset and stays
// in the chart at state.mean: the update changes the offset and the covariance (in that
// chart) but neither moves the mean nor re-charts the covariance. A sequence of such updates
// linearised about one point is then exactly one Gauss-Newton step, however far the chart's
// origin is from that point; moving the chart after each update instead leaves an error of
// second order in the steps, which stalled a robot arm started 0.4 rad away at 1e-4.
// RetractOffset() ends such a sequence.
FusionSummary Fuse(const Factor& factor, GaussianState* state, const FusionOptions& options = {},
                   const Values* linearize_at = nullptr, Eigen::VectorXd* offset = nullptr);

// Moves the state to mean ⊞ offset and its covariance to the chart there; zeroes the offset.
void RetractOffset(GaussianState* state, Eigen::VectorXd* offset);

// Fuses a sequence of factors in order. One pass is exact for linear factors. For nonlinear
// ones, a later update may move the state along directions an earlier constraint's
// linearisation allowed, leaving that constraint violated to second order; so while some
// constraint's residual exceeds `constraint_tolerance`, the whole sequence is fused again
// from the prior with every factor linearised once about the previous pass's estimate. A
// sequence of Kalman updates all linearised about one point, in one chart (Fuse's `offset`),
// solves that linearised problem exactly, so each such pass is a Gauss-Newton step on all the
// factors at once, and the passes converge to the batch solution (batch_solver.h).
//
// Converged means: every constraint within `constraint_tolerance`, after a Gauss-Newton pass
// whose step is within a tenth of each coordinate's standard deviation (the first pass counts
// only when every factor is affine). Inequalities g - λ² = 0: after each pass every slack is
// set from its constraint, λ = ±√max(g, 0), and to exactly 0 within 100 tolerances of the
// boundary; one on its boundary (an equality in the linearisation) is released by an
// active-set test — a pass without the boundary inequalities — when the data pull inside (at
// most 3 tests per sequence, each followed by up to max_passes more). Passes beyond max_passes
// are allowed while each at least halves the constraints' residual (up to 4 x max_passes).
struct SequenceOptions {
  FusionOptions fusion;
  int max_passes = 8;
  double constraint_tolerance = 1e-10;  // max |c(x)| accepted, in the residuals' units
  // The first pass too is a Gauss-Newton step about the prior's mean, for a start known to be
  // close (e.g. an interpretation tree's estimate). A factor's local iterations linearise it at
  // the estimate of the factors before it, which makes the pass depend on their order: a
  // point determined only at second order by its first constraints (a corner of a flat
  // quadrilateral held by three distances, before the coplanarity that pins it) is thrown
  // far along its free direction. Linearised about one point, the updates solve the
  // linearised problem exactly, in any order.
  bool gauss_newton_from_start = false;
  // An estimate that stays on an inequality's boundary (the data pull beyond it) gets the
  // covariance of the pass without its active inequalities: the boundary held as an equality
  // would claim it known to zero variance, while the truth may lie anywhere inside. For a
  // reported answer; a tracker, whose next search the covariance bounds, keeps the boundary.
  bool boundary_free_covariance = false;
};

struct SequenceSummary {
  int passes = 0;
  bool converged = false;              // every constraint within tolerance
  double max_constraint_residual = 0;  // at the final estimate
  std::vector<FusionSummary> fusions;  // of the last pass, one per factor
};

SequenceSummary FuseSequence(const std::vector<Factor>& factors, GaussianState* state,
                             const SequenceOptions& options = {});

// What the state predicts for a factor's residual function h (its value at the mean and its
// covariance H P Hᵀ, the factor's own noise not included): for a measurement residual
// h(x) - z built with z = 0, the predicted measurement. `valid` is false when h or its
// Jacobian is not finite there (e.g. a point behind a pinhole camera).
struct Prediction {
  Eigen::VectorXd mean;
  Eigen::MatrixXd covariance;
  bool valid = false;
};
Prediction Predict(const Factor& factor, const GaussianState& state);

// The largest |c_k(x)| over the constraint factors at `values`.
double MaxConstraintResidual(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                             const Values& values);

}  // namespace cfuse
