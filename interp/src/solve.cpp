#include "cfuse/interp/solve.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>

#include "cfuse/interp/closed_form_pose.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/schedule.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/did_you_mean.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/fusion_order.h"
#include "cfuse/kernel/measurements/image_point.h"
#include "cfuse/kernel/measurements/point3.h"
#include "cfuse/kernel/measurements/stacked.h"
#include "cfuse/kernel/sparse_solver.h"
#include "reduced_solver.h"
#include "solve_internal.h"

namespace cfuse {

using internal::ExploreStarts;
using internal::NormalisedSquare;
using internal::PlaceUnmeasured;
using internal::SolveLabelled;

namespace {

// The residual of a labelled measurement: its model point's position or projection minus it.
std::shared_ptr<const ResidualFunction> MeasurementResidual(const ConstraintGraph& graph,
                                                            const MeasurementSet& set,
                                                            const ResolvedLabel& r) {
  const MeasuredPoint& m = set.points[r.measurement];
  const Component& comp = graph.components[r.component];
  if (m.is_3d) {
    if (comp.rigid) {
      return std::make_shared<Point3Residual>(comp.points[r.feature].position, m.xyz);
    }
    return std::make_shared<Point3Residual>(m.xyz);
  }
  if (comp.rigid) {
    return std::make_shared<ImagePointResidual>(*set.camera, comp.points[r.feature].position, m.uv);
  }
  return std::make_shared<ImagePointResidual>(*set.camera, m.uv);
}

// A measurement's distance from the estimate in the spread its residual should have there:
// rᵀ S⁻¹ r with S = R − A P Aᵀ for a measurement the estimate includes (what is left of its
// noise once the estimate has leant on it: the same as its distance from the estimate without
// it), and S = R + A P Aᵀ for one it does not. Chi-square with the measurement's dimension for
// a good measurement either way. A measurement the estimate follows exactly (a single point
// measured once, with nothing else to check it) cannot be judged: 0.
double GateSquare(const ConstraintGraph& graph, const MeasurementSet& set, const ResolvedLabel& r,
                  const GaussianState& state, bool included) {
  const MeasuredPoint& m = set.points[r.measurement];
  const int block = graph.components[r.component].block;
  Eigen::VectorXd residual;
  Eigen::MatrixXd a;
  EvaluateResidual(*MeasurementResidual(graph, set, r), graph.blocks, {&block, 1}, state.mean,
                   &residual, &a);
  if (!residual.allFinite() || !a.allFinite()) return INFINITY;
  const Block& b = graph.blocks[block];
  const int dim = TangentDim(b.kind);
  const Eigen::MatrixXd noise = m.is_3d ? Eigen::MatrixXd(m.cov3) : Eigen::MatrixXd(m.cov2);
  const Eigen::MatrixXd spread =
      a * state.covariance.block(b.tangent_offset, b.tangent_offset, dim, dim) * a.transpose();
  const Eigen::MatrixXd s =
      included ? Eigen::MatrixXd(noise - spread) : Eigen::MatrixXd(noise + spread);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(s);
  if (!(eigen.eigenvalues().minCoeff() > 1e-6 * noise.trace())) return 0;
  return residual.dot(s.llt().solve(residual));
}

// The start of a labelled solve, and the same before unmeasured points are placed (the
// fallback when the placed one ends on a minimum the measurements do not fit).
struct LabelledStart {
  Values initial, unplaced;
};

LabelledStart SolveStart(const ConstraintGraph& graph, const MeasurementSet& set,
                         const SolveOptions& options, const std::vector<ResolvedLabel>& labels,
                         const Values* start) {
  // A guess that places every component makes the closed-form starts moot (the interpretation
  // tree's final solves pass one).
  const bool guess_covers_all =
      options.guess &&
      std::all_of(graph.components.begin(), graph.components.end(), [&](const Component& c) {
        const auto named = [&](const auto& list) {
          return std::any_of(list.begin(), list.end(),
                             [&](const auto& e) { return e.name == c.name; });
        };
        return named(options.guess->components) || named(options.guess->points);
      });
  Values initial = start              ? *start
                   : guess_covers_all ? graph.nominal
                                      : ClosedFormStart(graph, set, labels);

  Values unplaced;
  if (start) {
    unplaced = initial;
    MatchSlacks(graph, &unplaced);
  } else if (options.guess) {
    ApplyGuess(graph, *options.guess, &initial);
  } else {
    unplaced = initial;
    MatchSlacks(graph, &unplaced);
    std::vector<bool> measured(graph.components.size(), false);
    for (const ResolvedLabel& r : labels) measured[r.component] = true;
    bool any_to_place = false;
    for (size_t c = 0; c < graph.components.size(); ++c) {
      if (graph.components[c].rigid) measured[c] = true;  // placed by their closed forms
      any_to_place = any_to_place || !measured[c];
    }
    if (!any_to_place || !options.use_constraints_between_components) {
      return {unplaced, std::move(unplaced)};  // nothing to place: the same start twice
    }
    PlaceUnmeasured(graph, measured, &initial);
  }
  MatchSlacks(graph, &initial);
  return {std::move(initial), std::move(unplaced)};
}

// Per factor: the first residual row and the label (its index in the labels) of each
// measurement it stacks; named only when one is reported.
using StackedNames = std::vector<std::vector<std::pair<int, int>>>;

// The factors of a labelled solve: one factor per single point measurement, and one per rigid
// component stacking all its measurements (measurements/stacked.h), in the order of their
// first measurement, then the constraints in the graph's order (FusionOrder puts them in the
// filter's). An image measurement whose point is at or behind the camera at `initial` is left
// out and reported in `invalid`. For each factor, `stacked` gets the first residual row and
// the label of each measurement it stacks.
std::vector<Factor> SolveFactors(const ConstraintGraph& graph, const MeasurementSet& set,
                                 const SolveOptions& options,
                                 const std::vector<ResolvedLabel>& labels, const Values& initial,
                                 std::vector<std::string>* invalid, StackedNames* stacked) {
  // A marker's noise, 2 x 2 or 3 x 3, held without an allocation of its own.
  using Noise = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;
  std::vector<Factor> factors;
  factors.reserve(graph.components.size() + graph.constraints.size());
  std::vector<int> component_factor(graph.components.size(), -1);
  std::vector<std::vector<std::shared_ptr<const ResidualFunction>>> parts;
  std::vector<std::vector<Noise>> noises;
  std::vector<int> rows;  // per stacked factor, its rows so far
  for (size_t label = 0; label < labels.size(); ++label) {
    const ResolvedLabel& r = labels[label];
    const MeasuredPoint& m = set.points[r.measurement];
    const Component& comp = graph.components[r.component];
    std::shared_ptr<const ResidualFunction> f = MeasurementResidual(graph, set, r);
    if (!m.is_3d && !std::isfinite(NormalisedSquare(graph, set, r, initial))) {
      // No projection there (Camera::Project). In its component's stacked factor it would make
      // every measurement of the component invalid, and the component silently unmeasured.
      invalid->push_back(fmt::format(
          "measurement {} ({}): its model point is at or behind the camera at the start",
          r.measurement, m.label));
      continue;
    }
    Noise noise;
    if (m.is_3d) {
      noise = m.cov3;
    } else {
      noise = m.cov2;
    }
    if (!comp.rigid) {
      factors.push_back({std::move(f),
                         {comp.block},
                         Eigen::MatrixXd(noise),
                         fmt::format("measurement {} ({})", r.measurement, m.label)});
      parts.emplace_back();
      noises.emplace_back();
      rows.push_back(0);
      continue;
    }
    int& k = component_factor[r.component];
    if (k < 0) {
      k = static_cast<int>(factors.size());
      factors.push_back({nullptr, {comp.block}, {}, fmt::format("measurements of {}", comp.name)});
      parts.emplace_back();
      noises.emplace_back();
      rows.push_back(0);
    }
    if (stacked->size() <= static_cast<size_t>(k)) stacked->resize(static_cast<size_t>(k) + 1);
    (*stacked)[k].emplace_back(rows[k], static_cast<int>(label));
    rows[k] += static_cast<int>(noise.rows());
    parts[k].push_back(std::move(f));
    noises[k].push_back(noise);
  }
  for (size_t k = 0; k < factors.size(); ++k) {
    if (factors[k].residual) continue;
    factors[k].residual = std::make_shared<StackedResidual>(std::move(parts[k]));
    const int dim = factors[k].residual->dimension();
    factors[k].noise = Eigen::MatrixXd::Zero(dim, dim);
    int offset = 0;
    for (const Noise& n : noises[k]) {
      factors[k].noise.block(offset, offset, n.rows(), n.cols()) = n;
      offset += static_cast<int>(n.rows());
    }
  }
  for (const Constraint& c : graph.constraints) {
    if (options.use_constraints_between_components || ConstraintComponents(graph, c).size() <= 1)
      factors.push_back({c.residual, c.blocks, {}, c.name});
  }
  return factors;
}

// The factors in the order that keeps the filter's correlation groups small (the measurements
// first, as they are, so `stacked` still indexes them). The batch solvers take any order; the
// sparse one is given this one too, its dependent rows then left out as before.
void FusionOrder(const ConstraintGraph& graph, std::vector<Factor>* factors) {
  std::vector<Factor> ordered;
  ordered.reserve(factors->size());
  for (int i : GroupGrowthOrder(*factors, static_cast<int>(graph.blocks.size()))) {
    ordered.push_back(std::move((*factors)[i]));
  }
  *factors = std::move(ordered);
}

// Whether the estimate leaves free something that measurement `r` (left out) would measure:
// its Jacobian moves along a free direction of the solution's analysis.
bool Unchecked(const ConstraintGraph& graph, const MeasurementSet& set, const ResolvedLabel& r,
               const Solution& solution) {
  const Eigen::MatrixXd& free = solution.analysis.free_directions;
  if (free.cols() == 0) return false;
  const int block = graph.components[r.component].block;
  Eigen::VectorXd residual;
  Eigen::MatrixXd a;
  EvaluateResidual(*MeasurementResidual(graph, set, r), graph.blocks, {&block, 1},
                   solution.state.mean, &residual, &a);
  if (!a.allFinite()) return false;
  const Block& b = graph.blocks[block];
  for (int i = 0; i < a.rows(); ++i) {
    Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(free.rows());
    row.segment(b.tangent_offset, TangentDim(b.kind)) = a.row(i);
    if (MovesAlong(row, free)) return true;
  }
  return false;
}

// The components and joints that the free directions of the solution's analysis move.
std::vector<std::string> UndeterminedNames(const ConstraintGraph& graph, const Solution& solution) {
  std::vector<std::string> out;
  const Eigen::MatrixXd& free = solution.analysis.free_directions;
  if (free.cols() == 0) return out;
  for (const Component& c : graph.components) {
    const Block& b = graph.blocks[c.block];
    if (free.middleRows(b.tangent_offset, TangentDim(b.kind)).norm() > 1e-6) {
      out.push_back(c.name);
    }
  }
  const Eigen::MatrixXd joints = JointJacobian(graph, solution.state.mean);
  int row = 0;
  for (const Joint& j : graph.joints) {
    if (!HasJointVariable(j.type)) continue;
    if (MovesAlong(joints.row(row), free)) out.push_back("joint " + j.name);
    ++row;
  }
  return out;
}

// Each block's own covariance and each pair's in `pairs` from `estimate` into state's
// covariance, NaN elsewhere.
void StoreReported(const ConstraintGraph& graph, const SparseEstimate& estimate,
                   const std::vector<std::pair<int, int>>& pairs, GaussianState* state) {
  const int n = graph.tangent_dim();
  state->covariance.setConstant(n, n, NAN);
  auto put = [&](int a, int b) {
    const Block &ba = graph.blocks[a], &bb = graph.blocks[b];
    const Eigen::MatrixXd c = estimate.Covariance(a, b);
    state->covariance.block(ba.tangent_offset, bb.tangent_offset, c.rows(), c.cols()) = c;
    state->covariance.block(bb.tangent_offset, ba.tangent_offset, c.cols(), c.rows()) =
        c.transpose();
  };
  for (size_t b = 0; b < graph.blocks.size(); ++b) put(static_cast<int>(b), static_cast<int>(b));
  for (const auto& [a, b] : pairs) put(a, b);
}

// Whether a batch solver's answer is one the filter would give: converged with every
// constraint within tolerance, no inequality on its boundary as FuseSequence judges it (λ²
// within a hundred constraint tolerances: the filter's active-set test decides those). Its fit
// is judged apart (Accepted).
bool Settled(const ConstraintGraph& graph, bool converged, double max_constraint_residual,
             const Values& mean, const SequenceOptions& sequence) {
  if (!converged || !(max_constraint_residual <= sequence.constraint_tolerance)) return false;
  constexpr double kBoundary = 100;
  for (const Constraint& c : graph.constraints) {
    if (c.slack_block < 0) continue;
    const double lambda = mean.slacks[graph.blocks[c.slack_block].index];
    if (lambda * lambda <= kBoundary * sequence.constraint_tolerance) return false;
  }
  return true;
}

// A fit the solution accepts.
bool Accepted(const Fit& fit, const SolveOptions& options) {
  return fit.p_value >= options.min_p_value;
}

// The pairs of blocks whose covariance results report besides each block's own: each joint's
// parent and child (the joint's variance).
std::vector<std::pair<int, int>> JointPairs(const ConstraintGraph& graph) {
  std::vector<std::pair<int, int>> pairs;
  for (const Joint& j : graph.joints) {
    if (j.parent >= 0 && j.child >= 0) {
      pairs.emplace_back(graph.components[j.parent].block, graph.components[j.child].block);
    }
  }
  return pairs;
}

// A batch solver's answer as the filter's summary: converged, every factor fused whole.
void BatchSummary(const std::vector<Factor>& factors, int iterations,
                  double max_constraint_residual, SequenceSummary* summary) {
  *summary = SequenceSummary{};
  summary->passes = iterations;
  summary->converged = true;
  summary->max_constraint_residual = max_constraint_residual;
  for (const Factor& f : factors) {
    FusionSummary fused;
    fused.rows = fused.rows_fused = f.residual->dimension();
    summary->fusions.push_back(fused);
  }
}

// The sparse solver's answer (sparse_solver.h) as a Solution's state and summary, when it is
// one the filter would give: converged, every constraint within tolerance, no inequality on
// its boundary (the filter's active-set test decides those), and a fit the solution accepts.
// False otherwise, the filter then solving from the start as before. A large model's
// covariance holds what results report, each block's own and each joint's pair of components
// (the joint's variance): the rest would cost n solves with the factor (50 ms for 850
// dimensions), more than the whole solve, and is NaN, not computed, rather than a number that
// is not the covariance. A small model's is whole.
bool SolveSparseFirst(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                      const Values& initial, const PriorScale& scale,
                      const SequenceOptions& sequence, const SolveOptions& options,
                      Solution* solution, Fit* fit) {
  SparseOptions sparse;
  sparse.constraint_tolerance = sequence.constraint_tolerance;
  sparse.full_covariance = graph.tangent_dim() < options.full_covariance_below;
  const std::vector<std::pair<int, int>> pairs =
      sparse.full_covariance ? std::vector<std::pair<int, int>>{} : JointPairs(graph);
  SparseEstimate estimate;
  const SparseSummary s =
      SolveSparse(factors, graph.blocks, initial, PriorVariance(graph.blocks, scale), pairs,
                  &estimate, sparse, &initial);
  if (!Settled(graph, s.factorized && s.converged, s.max_constraint_residual, estimate.mean,
               sequence)) {
    return false;
  }
  *fit = AnalyseFit(factors, graph.blocks, estimate.mean, solution->extent, false).fit;
  if (!Accepted(*fit, options)) return false;
  GaussianState& state = solution->state;
  state.mean = std::move(estimate.mean);
  if (sparse.full_covariance) {
    state.covariance = estimate.full_covariance();
  } else {
    StoreReported(graph, estimate, pairs, &state);
  }
  BatchSummary(factors, s.iterations, s.max_constraint_residual, &solution->summary);
  return true;
}

// The same with the forest's joints eliminated (reduced_solver.h), on the same conditions,
// for a model with joints and fewer than SolveOptions::reduced_below parameters. Its fit
// analysis, counted on the forest's parameters, in `analysis` when it has one (`analysed`).
bool SolveReducedFirst(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                       const Values& initial, const PriorScale& scale,
                       const SequenceOptions& sequence, const SolveOptions& options,
                       Solution* solution, Fit* fit, bool* analysed) {
  *analysed = false;
  if (options.reduced_below <= 0 || graph.joints.empty()) return false;
  internal::ReducedOptions reduced;
  reduced.constraint_tolerance = sequence.constraint_tolerance;
  reduced.fit_extent = solution->extent;
  reduced.max_parameters = options.reduced_below - 1;
  internal::ReducedEstimate estimate;
  const std::vector<std::pair<int, int>> pairs = JointPairs(graph);
  const internal::ReducedSummary s = internal::SolveReduced(
      graph, factors, initial, PriorVariance(graph.blocks, scale), &estimate, reduced, &initial,
      graph.tangent_dim() < options.full_covariance_below ? nullptr : &pairs);
  if (!s.unsupported.empty()) return false;
  if (!Settled(graph, s.factorized && s.converged, s.max_constraint_residual, estimate.mean,
               sequence)) {
    return false;
  }
  *fit = estimate.analysed
             ? estimate.analysis.fit
             : AnalyseFit(factors, graph.blocks, estimate.mean, solution->extent, false).fit;
  if (!Accepted(*fit, options)) return false;
  GaussianState& state = solution->state;
  state.mean = std::move(estimate.mean);
  state.covariance = std::move(estimate.covariance);
  BatchSummary(factors, s.iterations, s.max_constraint_residual, &solution->summary);
  if (estimate.analysed) solution->analysis = std::move(estimate.analysis);
  *analysed = estimate.analysed;
  return true;
}

}  // namespace

namespace internal {

double NormalisedSquare(const ConstraintGraph& graph, const MeasurementSet& set,
                        const ResolvedLabel& r, const Values& values) {
  const MeasuredPoint& m = set.points[r.measurement];
  const int block = graph.components[r.component].block;
  Eigen::VectorXd residual;
  EvaluateResidual(*MeasurementResidual(graph, set, r), graph.blocks, {&block, 1}, values,
                   &residual, nullptr);
  if (!residual.allFinite()) return INFINITY;
  if (m.is_3d) return residual.dot(m.cov3.llt().solve(Eigen::Vector3d(residual)));
  return residual.dot(m.cov2.llt().solve(Eigen::Vector2d(residual)));
}

void SolveLabelled(const ConstraintGraph& graph, const MeasurementSet& set,
                   const SolveOptions& options, const std::vector<ResolvedLabel>& labels,
                   Solution* solution, const Values* start, const Eigen::VectorXd* pinned) {
  solution->contradictions.clear();
  solution->invalid.clear();

  const auto [initial, unplaced] = SolveStart(graph, set, options, labels, start);

  // 3. The prior, and 4. the factors.
  PriorScale scale;
  scale.position = options.prior_extent_factor * solution->extent;
  scale.rotation = options.prior_rotation_sigma;
  scale.slack = options.prior_slack_sigma;
  // A pinned functional has zero prior variance, so no update moves it (uᵀ P = 0 makes uᵀ K = 0).
  const auto prior = [&](const Values& mean) {
    GaussianState state = MakePrior(graph.blocks, mean, scale);
    if (pinned) {
      const Eigen::VectorXd Pu = state.covariance * *pinned;
      state.covariance -= Pu * Pu.transpose() / pinned->dot(Pu);
      state.groups.MergeAll();
    }
    return state;
  };
  // The prior's blocks, variances and groups, as a batch answer keeps them; its dense covariance
  // only where the filter runs (below): for a large model that alone cost more than the
  // reduced solve.
  solution->state = GaussianState{};
  solution->state.blocks = graph.blocks;
  solution->state.prior_variance = PriorVariance(graph.blocks, scale);
  solution->state.groups = CorrelationGroups(static_cast<int>(graph.blocks.size()));
  StackedNames stacked;
  std::vector<Factor> factors =
      SolveFactors(graph, set, options, labels, initial, &solution->invalid, &stacked);
  SequenceOptions sequence = options.sequence;
  sequence.constraint_tolerance = 1e-8 * solution->extent;
  // An answer on a limit does not claim the limit known to zero variance (a Stewart platform
  // seen by one camera, a leg estimated on its range's end and truly well inside it: the top
  // plate 135 mm off, NEES 62 under the covariance that held the boundary, 54 without it).
  sequence.boundary_free_covariance = true;
  Fit fit;
  bool analysed = false;  // solution->analysis is the answer's
  const bool batch = !pinned && graph.tangent_dim() >= options.sparse_from_dim;
  solution->estimator = Estimator::kFilter;
  if (batch && SolveReducedFirst(graph, factors, initial, scale, sequence, options, solution, &fit,
                                 &analysed)) {
    solution->estimator = Estimator::kReduced;
  } else {  // (a reduced answer is acceptable: the filter's tries below never follow it)
    FusionOrder(graph, &factors);
    if (batch &&
        SolveSparseFirst(graph, factors, initial, scale, sequence, options, solution, &fit)) {
      solution->estimator = Estimator::kSparse;
    }
  }
  const bool batch_answered = solution->estimator != Estimator::kFilter;
  if (!batch_answered) {
    solution->state = prior(initial);
    solution->summary = FuseSequence(factors, &solution->state, sequence);
  }
  // A converged estimate that the measurements do not fit is a local minimum as surely as an
  // unconverged one is a failure: both get the other starts, and the better fit is kept.
  const auto chi2 = [&](const GaussianState& state) {
    return AnalyseFit(factors, graph.blocks, state.mean, solution->extent, false).fit;
  };
  if (!batch_answered) fit = chi2(solution->state);
  const auto acceptable = [&] {
    return solution->summary.converged && fit.p_value >= options.min_p_value;
  };
  const auto better = [&](const SequenceSummary& summary, const Fit& other) {
    if (summary.converged != solution->summary.converged) return summary.converged;
    if (!summary.converged) {
      return summary.max_constraint_residual < solution->summary.max_constraint_residual;
    }
    return other.chi2 < fit.chi2;
  };
  if (!acceptable() && !options.guess && !start) {
    // Placing unmeasured points can still pick the wrong one of two places their constraints
    // allow (a mirror image about their neighbours); the unplaced start is the second try.
    GaussianState state = prior(unplaced);
    SequenceSummary summary = FuseSequence(factors, &state, sequence);
    const Fit other = chi2(state);
    if (better(summary, other)) {
      solution->state = std::move(state);
      solution->summary = std::move(summary);
      solution->estimator = Estimator::kFilter;
      fit = other;
    }
  }
  if (!acceptable() && !sequence.gauss_newton_from_start) {
    // Noisy data on short lever arms (the lamp's hinge points 30 mm apart under 10 mm noise)
    // can throw the first pass's local iterations far off, each constraint linearised where
    // the ones before it left the estimate. A Gauss-Newton pass from the start, every factor
    // linearised there, is the last try (it brought 6 of 10 such lamps back).
    SequenceOptions from_start = sequence;
    from_start.gauss_newton_from_start = true;
    GaussianState state = prior(initial);
    SequenceSummary summary = FuseSequence(factors, &state, from_start);
    const Fit other = chi2(state);
    if (better(summary, other)) {
      solution->state = std::move(state);
      solution->summary = std::move(summary);
      solution->estimator = Estimator::kFilter;
      fit = other;
    }
  }
  if (solution->estimator != Estimator::kReduced || !analysed) {
    solution->analysis = AnalyseFit(factors, graph.blocks, solution->state.mean, solution->extent);
  }
  for (size_t i = 0; i < factors.size(); ++i) {
    if (solution->summary.fusions[i].status == FusionSummary::Status::kContradiction) {
      solution->contradictions.push_back(factors[i].name);
    }
    const FusionSummary& fusion = solution->summary.fusions[i];
    if (fusion.status == FusionSummary::Status::kInvalid) {
      std::string culprit;
      for (const auto& [first_row, label] :
           i < stacked.size() ? stacked[i] : StackedNames::value_type{}) {
        const ResolvedLabel& r = labels[label];
        if (fusion.invalid_row >= first_row) {
          culprit =
              fmt::format("measurement {} ({})", r.measurement, set.points[r.measurement].label);
        }
      }
      solution->invalid.push_back(
          factors[i].name + ": not finite at the estimate" +
          (culprit.empty() || fusion.invalid_row < 0 ? "" : ", first at " + culprit));
    }
  }
}

}  // namespace internal

Eigen::Vector3d ModelPoint(const ConstraintGraph& graph, const Values& values, int component,
                           int feature) {
  const Component& c = graph.components[component];
  const Block& b = graph.blocks[c.block];
  if (!c.rigid) return values.points[b.index];
  return values.poses[b.index] * c.points[feature].position;
}

double ModelExtent(const ConstraintGraph& graph) {
  // Every model point at the nominal values, and each rigid component's origin; visited twice
  // (their centre, then the farthest from it) rather than stored: every solve asks.
  const auto for_each_point = [&](const auto& visit) {
    for (size_t c = 0; c < graph.components.size(); ++c) {
      const Component& comp = graph.components[c];
      if (!comp.rigid) visit(ModelPoint(graph, graph.nominal, static_cast<int>(c), -1));
      for (size_t f = 0; f < comp.points.size(); ++f) {
        visit(ModelPoint(graph, graph.nominal, static_cast<int>(c), static_cast<int>(f)));
      }
      if (comp.rigid) visit(graph.nominal.poses[graph.blocks[comp.block].index].translation);
    }
  };
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  size_t count = 0;
  for_each_point([&](const Eigen::Vector3d& p) {
    centre += p;
    ++count;
  });
  centre /= static_cast<double>(std::max<size_t>(1, count));
  double extent = 1e-3;
  for_each_point([&](const Eigen::Vector3d& p) { extent = std::max(extent, (p - centre).norm()); });
  return extent;
}

void RequireEstimable(const ConstraintGraph& graph) {
  const int dim = graph.tangent_dim();
  if (dim <= kMaxStateDim) return;
  throw InputError(SourceLocation(graph.source),
                   fmt::format("model '{}' has a state of {} dimensions ({} components, {} "
                               "constraints); the estimator's dense covariance is limited to {} "
                               "dimensions ({:.2f} GB)",
                               graph.name, dim, graph.components.size(), graph.constraints.size(),
                               kMaxStateDim, 8.0 * kMaxStateDim * kMaxStateDim / 1e9));
}

bool Distinct(const ConstraintGraph& graph, const Values& other, const GaussianState& best,
              double extent) {
  for (const Component& c : graph.components) {
    const Block& block = graph.blocks[c.block];
    const int o = block.tangent_offset;
    if (block.kind == BlockKind::kPose) {
      const Rigid3d& pa = other.poses[block.index];
      const Rigid3d& pb = best.mean.poses[block.index];
      const double turn_sigma = std::sqrt(
          std::max(0.0, best.covariance.block<3, 3>(o, o).eigenvalues().real().maxCoeff()));
      const double move_sigma = std::sqrt(
          std::max(0.0, best.covariance.block<3, 3>(o + 3, o + 3).eigenvalues().real().maxCoeff()));
      if (pa.rotation.angularDistance(pb.rotation) > std::max(3 * M_PI / 180, 3 * turn_sigma) ||
          (pa.translation - pb.translation).norm() > std::max(0.05 * extent, 3 * move_sigma)) {
        return true;
      }
    } else if (block.kind == BlockKind::kPoint) {
      const double move_sigma = std::sqrt(
          std::max(0.0, best.covariance.block<3, 3>(o, o).eigenvalues().real().maxCoeff()));
      if ((other.points[block.index] - best.mean.points[block.index]).norm() >
          std::max(0.05 * extent, 3 * move_sigma)) {
        return true;
      }
    }
  }
  return false;
}

Solution Solve(const ConstraintGraph& graph, const MeasurementSet& set,
               const SolveOptions& options) {
  CheckGraph(graph);
  CheckMeasurementSet(set);
  RequireEstimable(graph);
  Solution solution;
  solution.labels = ResolveLabels(graph, set);
  solution.extent = ModelExtent(graph);
  std::vector<ResolvedLabel> used = solution.labels;
  const size_t max_rejected = used.size() / 5;
  // Constants, computed once (a quantile costs more than a small robot's whole solve).
  static const double gate_3d = ChiSquareQuantile(1 - 1e-9, 3);
  static const double gate_2d = ChiSquareQuantile(1 - 1e-9, 2);
  // Outliers are judged at the best of the minima, not at the first one found.
  const bool image = std::any_of(used.begin(), used.end(), [&](const ResolvedLabel& r) {
    return !set.points[r.measurement].is_3d;
  });
  const auto solve = [&] {
    SolveLabelled(graph, set, options, used, &solution);
    solution.fits = solution.analysis.fit.p_value >= options.min_p_value;
    solution.alternatives.clear();
    solution.valleys.clear();
    if (options.explore_starts && image && !options.guess) {
      ExploreStarts(graph, set, options, used, &solution);
    }
  };
  while (true) {
    solve();
    if (!options.reject_outliers || solution.rejected.size() >= max_rejected) break;
    // The measurement farthest beyond its gate; one at a time, as an outlier drags the others.
    int worst = -1;
    double worst_excess = 1, worst_square = 0;
    for (size_t i = 0; i < used.size(); ++i) {
      const double square = GateSquare(graph, set, used[i], solution.state, true);
      const double excess = square / (set.points[used[i].measurement].is_3d ? gate_3d : gate_2d);
      if (std::isfinite(square) && excess > worst_excess) {
        worst = static_cast<int>(i);
        worst_excess = excess;
        worst_square = square;
      }
    }
    if (worst < 0) break;
    solution.rejected.push_back({used[worst].measurement, std::sqrt(worst_square)});
    used.erase(used.begin() + worst);
  }
  // Outliers judged at the final estimate: one left out early, while another dragged the
  // estimate, may lie inside its gate once that one is gone; it comes back and the rest is
  // solved again (each measurement at most once, so this ends).
  std::vector<bool> once(set.points.size(), false);
  for (bool readmitted = true; readmitted && !solution.rejected.empty();) {
    readmitted = false;
    for (auto r = solution.rejected.begin(); r != solution.rejected.end();) {
      const auto label =
          std::find_if(solution.labels.begin(), solution.labels.end(),
                       [&](const ResolvedLabel& l) { return l.measurement == r->measurement; });
      const double square = GateSquare(graph, set, *label, solution.state, false);
      const double gate = set.points[r->measurement].is_3d ? gate_3d : gate_2d;
      // Inside its gate, or the only witness of something (the rest leave free what it
      // measures, so nothing can call it an outlier): it comes back.
      const bool inside = std::isfinite(square) && square <= gate;
      if ((inside || Unchecked(graph, set, *label, solution)) && !once[r->measurement]) {
        used.push_back(*label);
        once[r->measurement] = true;
        r = solution.rejected.erase(r);
        readmitted = true;
      } else {
        r->sigmas = std::sqrt(square);  // at the final estimate
        ++r;
      }
    }
    if (readmitted) {
      std::sort(used.begin(), used.end(), [](const ResolvedLabel& a, const ResolvedLabel& b) {
        return a.measurement < b.measurement;
      });
      solve();
    }
  }
  solution.undetermined = UndeterminedNames(graph, solution);
  return solution;
}

}  // namespace cfuse
