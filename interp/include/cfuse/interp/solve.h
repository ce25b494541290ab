// Pose estimation with known correspondences: every labelled measurement and every constraint
// of a model fused into one Gaussian estimate (Hel-Or & Werman §5, §7). The interpretation
// tree (a later issue) finds the labels; this is what it runs once they are known.
//
// Steps:
//  1. Labels are resolved to model points ("comp.point", or a point's name where unique).
//  2. Initial guess, because the filter linearises: the nominal geometry moved by the rigid
//     transform that best maps it onto the labelled measurements (absolute orientation,
//     Eigen::umeyama, from 3D points; a PnP solver from 2D points); then every rigid component
//     with enough labelled points gets its own closed-form pose and every measured single point
//     its measured position. None of this depends on how the object happens to be oriented.
//     A supplied guess (SolveOptions::guess) replaces these starts for the components and
//     points it names. Each inequality's slack is then set to match the start (λ = √g).
//  3. A vague prior centred on that guess (standard deviations: 10 x the model's extent for
//     positions, 1 rad for rotations, 10 for slacks): its weight next to a 2 mm measurement of
//     a 30 cm model is about 1e-7.
//  4. The measurements (in file order; a rigid component's together, in one update), then the
//     constraints (in the order of cfuse/kernel/fusion_order.h, which keeps the updates
//     small), fused by FuseSequence (cfuse/kernel/estimator.h) until every
//     constraint holds to 1e-8 x the model's extent. (Gauss-Newton passes reach about 1e-9 x
//     the extent before roundoff dominates when points are occluded: the vague prior then
//     leaves the covariance ill-conditioned.) The model is solved first in batch, every
//     factor at once: with its joints eliminated (SolveOptions::reduced_below) or by the
//     sparse solver (SolveOptions::sparse_from_dim); the filter runs only when that answer is
//     not one it would give (an inequality on its boundary, no convergence).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/fit_analysis.h"
#include "cfuse/kernel/measurement_set.h"
#include "cfuse/kernel/pose_set.h"

namespace cfuse {

struct SolveOptions {
  SequenceOptions sequence;
  double prior_extent_factor = 10.0;  // prior position sigma = factor x model extent
  double prior_rotation_sigma = 1.0;  // rad
  double prior_slack_sigma = 1e4;     // wide: near a limit the slack must move far (estimator.h)
  // Off: only the constraints within one component are fused, each component estimated from
  // its own measurements (the per-component baseline of the benchmarks, and the paper's
  // divide and conquer).
  bool use_constraints_between_components = true;
  // Starting poses and points by name (e.g. a previous result): they replace the closed-form
  // starts for what they name. An unknown name is an InputError at its entry.
  const PoseSet* guess = nullptr;
  // Gross outliers: while the measurement farthest from the estimate in its own noise is
  // beyond the chi-square gate at 1 - 1e-9 (6.8 sigma in 3D, 6.4 in an image), it is left out
  // and the rest solved again, a fifth of them at most (Solution::rejected). Off by default:
  // the interpretation tree gates its matches itself.
  bool reject_outliers = false;
  // The fit (cfuse/kernel/fit_analysis.h) below which a solution is refused: the chance that
  // measurements with the stated noise fit the model this badly.
  double min_p_value = 1e-3;
  // From image measurements, without a guess: solved again from the other closed-form start
  // and the mirror images of both (Solution::alternatives).
  bool explore_starts = true;
  // ... and when the best fit's p-value is below this, from the whole model posed at other
  // values of each joint too (0: never). `interpret` explores its answer's labelling so too
  // when the answer's fit is below it (its solves start from the tree's estimate).
  double explore_p_value = 0.05;
  // ... and each rigid part's fit profiled along its tilt towards its mirror image and away
  // (Solution::valleys): where it stays acceptable far beyond the covariance, the covariance is
  // widened to cover it.
  bool profile_valleys = true;
  // From this many tangent dimensions of state on, the labelled solve is tried first by the
  // sparse solver (cfuse/kernel/sparse_solver.h), whose cost follows the model's graph where
  // the filter's grows with the square of the state per update: its answer is kept when it
  // converged with no inequality on its boundary and a fit that passes, and the filter solves
  // as before otherwise. INT_MAX: the filter always.
  int sparse_from_dim = 0;
  // Below this many dimensions the sparse solver's covariance is computed whole (a solve with
  // its factor per dimension). From it on, only what results report: each component's own
  // block and each joint's pair of components (poses' and joints' sigmas); the entries between
  // other blocks are NaN, not computed, since they would cost more than the solve itself.
  // (Measured: docs/benchmarks.md, "Scale".)
  int full_covariance_below = 200;
  // A model with joints is tried first with the joints of its kinematic forest eliminated
  // (interp/src/reduced_solver.h) when that leaves fewer than this many parameters (root
  // poses and joint variables): the sparse solver's answer at about the parametric
  // form's cost, kept on the same conditions. Dense in those parameters: two humanoids' 114
  // are solved 2.7 times faster so than by the sparse solver, four humanoids' 228 1.4-4 times,
  // six humanoids' 342 about as fast, eight humanoids' 456 1.5 times slower
  // (docs/benchmarks.md, "Scale"). 0: never.
  int reduced_below = 256;
};

// Which estimator answered a labelled solve.
enum class Estimator {
  kFilter,   // the sequential filter (estimator.h)
  kSparse,   // the sparse solver (cfuse/kernel/sparse_solver.h)
  kReduced,  // the sparse solver's problem with the forest's joints eliminated
};

// A labelled measurement resolved to its model point.
struct ResolvedLabel {
  int measurement = -1;  // index into MeasurementSet::points
  int component = -1;
  int feature = -1;  // index into Component::points, or -1 for a single-point component
};

struct Solution {
  GaussianState state;
  SequenceSummary summary;
  std::vector<ResolvedLabel> labels;
  std::vector<std::string> contradictions;  // names of factors refused as contradictory
  // Factors and measurements not fused because their residual or its Jacobian was not finite
  // (an image point at or behind the camera, a zero length in a distance), and why.
  std::vector<std::string> invalid;
  struct Rejection {
    int measurement = -1;  // index into MeasurementSet::points
    double sigmas = 0;     // its distance from the estimate in its own noise, (rᵀ R⁻¹ r)^½
  };
  std::vector<Rejection> rejected;  // gross outliers left out (SolveOptions::reject_outliers)
  double extent = 0;                // the model's size, for relative tolerances
  // The measurements' chi-square at the estimate and the directions they leave free
  // (cfuse/kernel/fit_analysis.h); `undetermined` names the components and joints those move.
  FitAnalysis analysis;
  std::vector<std::string> undetermined;
  bool fits = true;  // analysis.fit.p_value >= SolveOptions::min_p_value
  // Other minima, distinct from this one, that the fit test does not reject either (from image
  // measurements: a near-planar part or the whole object mirrored), best fit first. The data
  // do not decide between them and the solution.
  struct Alternative {
    Values mean;
    Fit fit;
  };
  std::vector<Alternative> alternatives;
  // From one image (models whose covariance is computed whole, under full_covariance_below
  // dimensions): rigid components whose fit stays inside its 0.9999 profile interval while
  // they tilt (towards their mirror image about the line of sight, or away from it) to 6 or
  // more of the covariance's sigmas: a long curved valley that the local covariance does not
  // describe. The covariance is widened to cover the states found along it, and its far end
  // is among the alternatives unless one already lies there.
  struct Valley {
    std::string component;
    double towards_mirror = 0, away = 0;  // radians of tilt inside the interval, 0: Gaussian
  };
  std::vector<Valley> valleys;
  // Solved by the filter, the sparse solver (SolveOptions::sparse_from_dim) or the reduced one
  // (SolveOptions::reduced_below). From SolveOptions::full_covariance_below dimensions on, the
  // sparse solver's covariance holds each component's block and each joint's pair of
  // components only, NaN elsewhere.
  Estimator estimator = Estimator::kFilter;

  // Every constraint holds, nothing was contradictory or not finite, and the data fit.
  bool accepted() const {
    return summary.converged && fits && contradictions.empty() && invalid.empty();
  }
};

// The estimator's covariance is dense: 8 n² bytes for a state of n tangent dimensions (a rigid
// component 6, a single point 3, a slack 1). A model beyond kMaxStateDim (1.15 GB) is refused by
// Solve, Interpret, Simulate and the tracker up front, as an InputError naming the model file,
// rather than failing in an allocation; `check` and `fk` have no such limit.
inline constexpr int kMaxStateDim = 12000;
void RequireEstimable(const ConstraintGraph& graph);

// Resolves every label; an unknown or ambiguous label is an InputError at the measurement
// (with the closest known label), and so are labelled 3D points in other units than the
// model's: farther apart than the points they name by a factor of 20 or more.
std::vector<ResolvedLabel> ResolveLabels(const ConstraintGraph& graph, const MeasurementSet& set);

// The model's extent: the largest distance of a nominal point from their centroid (>= 1 mm).
double ModelExtent(const ConstraintGraph& graph);

// Whether `other` is a different answer from `best`: a component turned or moved beyond both
// a floor (3 degrees, 5 % of the model's extent) and three standard deviations of `best`'s
// estimate (the largest, along any axis), so that two starts ending in one flat valley are
// one answer.
bool Distinct(const ConstraintGraph& graph, const Values& other, const GaussianState& best,
              double extent);

Solution Solve(const ConstraintGraph& graph, const MeasurementSet& set,
               const SolveOptions& options = {});

// Steps 1 and 2 above: the nominal geometry moved onto the labelled measurements, then every
// component with enough labels at its own closed-form pose (options.guess is not applied).
// `each_component` false: step 1 alone, the nominal geometry moved as one body.
Values ClosedFormStart(const ConstraintGraph& graph, const MeasurementSet& set,
                       const std::vector<ResolvedLabel>& labels, bool each_component = true);

// The guess's poses and points in place of `values`' (a merged link's frame places its
// component); an unknown name is an InputError at its entry.
void ApplyGuess(const ConstraintGraph& graph, const PoseSet& guess, Values* values);

// Moves single point `block` to where constraints `list` hold best, everything else in `x`
// fixed: Levenberg-Marquardt on the sum of their squared residuals. False when they or their
// Jacobians are not finite at the start.
struct PlaceOptions {
  int max_iterations = 30;
  double min_damping = 1e-9, max_damping = 1e9;  // bounds on the Levenberg-Marquardt lambda
};
bool PlacePoint(const ConstraintGraph& graph, const std::vector<int>& list, int block, Values* x,
                const PlaceOptions& options = {});

// The world position of a model point (component, feature) in `values`.
Eigen::Vector3d ModelPoint(const ConstraintGraph& graph, const Values& values, int component,
                           int feature);

}  // namespace cfuse
