// The interpretation tree (Hel-Or & Werman 1994, §6-§7): which measured points belong to which
// model points, found while the estimate is being built, so that every match made narrows the
// prediction of the next.
//
// Levels follow the fusion plan (schedule.h): at level k the constraints scheduled before it
// are fused, the model point of level k is predicted from the current estimate (mean t̂ and
// covariance Σ, through the measurement function: a 3D point, or its projection), and every
// unused measurement u′ with covariance Λ is scored by the Mahalanobis distance
//     δ = (t̂ - u′)ᵀ (Σ + Λ)⁻¹ (t̂ - u′)
// and gated at the chi-square quantile of the gate confidence. Survivors are fused tentatively
// (with local iterations), best first; a null branch at every level stands for an occluded
// point: the paper's artificial measurement of infinite uncertainty, i.e. nothing is fused and
// the point stays estimated through its constraints. A branch is dropped when a fusion fails
// (a contradiction, a non-finite prediction, local iterations that do not settle) or a
// constraint fused after the matches it depends on disagrees with them: its NIS, taken at its
// converged linearisation (FusionSummary::final_nis), exceeds the chi-square quantile for its
// rows.
//
// The search is depth first, children best first, by iterative deepening on occlusions: a
// round allows at most k null branches, k = 0, 1, 2, ..., and the first complete
// interpretation found ends the search, so it has the most matches there are below its seed.
// Deepening matters: a wrong early choice can only be followed by nulls below it, and a round
// abandons it as soon as it needs more than k of them, where a plain depth-first search would
// explore it to the bottom. A round does not search again what the last one did: it resumes
// only the null branches the last round had to leave (each kept with its frame), since all
// else below them was searched then. The node budget ends the search early (status kBudget;
// the best interpretation so far, or the branch that matched most).
//
// Blind points. A single point whose every constraint to the points before it waits on an
// occluded point (the wrist's side point when the wrist is occluded) predicts nothing: every
// measurement passes its gate and no constraint tests it, and a branch per measurement
// multiplies the tree below. It is postponed to the end of the branch, without counting as a
// null; by then the occluded neighbour has usually been placed from its other neighbours, and
// the point is predicted and matched like any other. Still blind there, it is left unmatched
// (a counted null).
//
// Occluded single points. The constraints on a point taken as occluded wait: fused where the
// point is guessed, they would pin it wrongly along any freedom its matched neighbours leave
// (a joint's angle). Once the waiting constraints whose other points are matched determine the
// point (their gradients span all three directions), it is placed where they hold best (a
// small Levenberg-Marquardt solve) and they are fused together as one factor
// (cfuse/kernel/combined_constraint.h): fused one at a time, a distance and a parallel axis
// that meet tangentially make the second one's iterations diverge. A leaf fuses whatever still
// waits.
//
// Seeds. Under the vague prior a pose is unknown, so gating the first points of the tree means
// nothing. The plan starts with a seed set from which a pose follows in closed form: a rigid
// triangle of single points or three features of a rigid component (3D data), four features
// (image data). Seed hypotheses are the measurement tuples consistent with the seed's
// geometry: pairwise distances within the gate (3D), or a P3P pose (cfuse/geometry/p3p.h)
// whose fourth point projects within the gate (2D). Each is scored by how many model points,
// placed rigidly with the nominal geometry at the seed's pose, find a measurement near them
// (within 5 % of the model's extent, or 3 % of the image diagonal), and the tree is searched
// below the best first; a later seed only if its support could beat the interpretation found,
// which it then must (more matches). The whole model starts at the seed's pose.
//
// Beyond the paper (InterpretOptions, measured in docs/benchmarks.md):
//  - joint compatibility (Neira & Tardós 2001): a branch is also dropped when its total
//    normalised innovation (every δ and every constraint NIS along it) exceeds the chi-square
//    quantile for its total dimension, which catches many small disagreements that each pass
//    their own gate;
//  - Lowe's match probability p/(p+q) (Lowe 1992, eq. 3): p the Gaussian density of the
//    innovation, q the clutter density (measurements per volume of their bounding box, or per
//    image area). Candidates are tried by decreasing probability, the null branch before any
//    candidate more likely clutter than the point (p/(p+q) < 1/2), and not at all once a
//    candidate with p/(p+q) >= 0.99 passed its tests;
//  - blind points postponed (postpone_blind, above), and one null per branch not counted in
//    the deepening where a sharp prediction finds no measurement (free_evidenced_nulls);
//  - re-association (refine_rounds): the interpretation's own estimate, from all its matches
//    and every constraint, predicts every point far better than the tree did when matching it
//    (an occluded point's neighbours on both sides). Measurements are re-associated to those
//    predictions by decreasing log(p/q), and a measurement matched to one point is offered to
//    an unmatched point whose gate holds it (the two faces of a thin plate, one occluded); a
//    new labelling replaces the old when its total log(p/q), under its own estimate, is higher.
#pragma once

#include <array>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/interp/schedule.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/measurement_set.h"

namespace cfuse {

// What an interpretation takes from the model alone, kept between interpretations of one model:
// its fusion plans (one per seed set and data kind) and its rigid triangles. The fusion order
// is the model's, computed before any data arrive (Hel-Or & Werman §6); a program that
// interprets many measurement sets of one model (a sequence of frames, a benchmark) passes one
// cache in InterpretOptions::plans and plans once. It belongs to one graph (checked), and may
// be shared between threads.
class PlanCache {
 public:
  explicit PlanCache(const ConstraintGraph& graph) : graph_(&graph) {}
  const ConstraintGraph& graph() const { return *graph_; }

  // The plan for data kind `image` starting at `start` (null: the automatic start), made by
  // `make` the first time.
  FusionPlan Plan(bool image, const PlanStart* start,
                  const std::function<FusionPlan()>& make) const;
  // The rigid triangles with or without the constraints between components.
  std::vector<std::array<int, 3>> Triangles(
      bool between_components, const std::function<std::vector<std::array<int, 3>>()>& make) const;

 private:
  const ConstraintGraph* graph_;
  mutable std::mutex mutex_;
  mutable std::map<std::tuple<bool, std::vector<int>, std::vector<int>>, FusionPlan> plans_;
  mutable std::map<bool, std::vector<std::array<int, 3>>> triangles_;
};

struct InterpretOptions {
  // Plans kept between interpretations of one model (above); null: planned afresh each time.
  const PlanCache* plans = nullptr;
  // Of the chi-square gates (matches and constraints). An interpretation of the lamp runs about
  // 80 such tests; at 0.999 one true match in ten trials failed one of them.
  double gate_confidence = 0.9999;
  long max_nodes = 20000;  // tree nodes (tentative fusions, null branches included)
  bool joint_compatibility = true;
  bool probability_order = true;
  // A single point whose every constraint to the points matched before it waits on an
  // occluded point predicts nothing (every measurement passes its gate): it is left unmatched
  // in the tree, placed through its constraints, and re-associated afterwards (refine_rounds),
  // instead of a branch per measurement.
  bool postpone_blind = true;
  // Null branches a branch may take without counting them in the iterative deepening, where
  // the prediction is sharp (its gate expects less than one clutter point) and no measurement
  // is in it: evidence of an occluded point rather than a choice, and no round is searched in
  // vain to prove it. The first leaf then need not have the most matches: a branch gone wrong
  // earlier (two interchangeable points swapped) can reach one, so few are allowed. Single
  // points only: a rigid component's features stand or fall with its pose, and a free null
  // hides the one feature that shows the pose wrong (the hinged box lost 4 % of its trials
  // without occlusion). With 1, the lamp is as often right as with 0, with fewer nodes and a
  // far shorter tail (docs/benchmarks.md).
  int free_evidenced_nulls = 1;
  // Off: constraints between components are ignored and each component is interpreted alone
  // (the paper's divide and conquer; a baseline).
  bool use_constraints_between_components = true;
  // Re-associations of the labelling against its own estimate (0: the tree's labelling as
  // found).
  int refine_rounds = 3;
  // After a complete search, up to this many further seeds, about as well supported as the
  // answer's and placing the model elsewhere, are searched for interpretations that match as
  // many points (a symmetric part turned onto itself, identical parts exchanged); those the
  // fit test does not reject become the solution's alternatives; within what the search left
  // of max_nodes. 0: none.
  int max_alternative_seeds = 4;
  // The answer read by the model's symmetries, at most this many readings (congruent parts
  // exchanged, a symmetric part turned onto itself: the same points, so the same fit unless a
  // constraint breaks): each re-fitted, and listed among the alternatives when accepted. 0:
  // none.
  int max_symmetric_readings = 16;
  SolveOptions solve;  // the final estimate from the matches found
};

struct SearchStats {
  enum class Status {
    kComplete,  // the tree was searched to the end: the best interpretation is the best
    kBudget,    // the node budget ended the search: the best found so far
  };
  Status status = Status::kComplete;
  long nodes = 0;       // tree nodes evaluated (tentative fusions, null branches included)
  long expanded = 0;    // of which passed their tests and were searched below
  long backtracks = 0;  // branches dropped as inconsistent
  int levels = 0;
  int seeds = 0;        // seed hypotheses found
  int seeds_tried = 0;  // of which searched below
  int refinements = 0;  // labellings replaced by their re-association
  // Image data: of the answer's matches found in the tree, those predicted before they were
  // seen, inside a gate that expected less than one clutter point (Lowe's evidence: the
  // matches that fix the pose predict nothing). -1 for 3D data, where a seed's own geometry is
  // evidence too, and for a branch the node budget cut short.
  int predicted = -1;
};
const char* StatusName(SearchStats::Status status);

// The paper's Figure 3: along the best branch, per level, the best-scored candidates and the
// constraints fused there.
struct TraceLevel {
  std::vector<int> constraints;
  int component = -1, feature = -1;
  int chosen = -1;                           // measurement matched, -1 for the null branch
  std::vector<std::pair<int, double>> best;  // up to 3 (measurement, δ), best first
};

struct Interpretation {
  std::vector<int> assignment;       // per plan level: the measurement matched, or -1
  std::vector<std::string> matches;  // per measurement: the model point, or "" (clutter)
  int matched = 0;
  double total_delta = 0;
  SearchStats stats;
  FusionPlan plan;
  std::vector<TraceLevel> trace;
  // The estimate from the matches (cfuse/interp/solve.h), when at least one point was matched.
  std::optional<Solution> solution;

  // Why the matches are no answer, or "" when they are one. Besides an estimate that is not
  // accepted (Solution::accepted): a search the node budget ended before it matched all model
  // points but two; and matches that leave some direction to the prior, or that fit with no residual
  // degrees of freedom, which would fit clutter as well as the object.
  std::string Refusal() const;
};

// The tree's tables and candidate lists grow with the square of the measurements, and its time
// faster (lamp, 1000 random points: 15 s and 160 MB; 3000: 2 min and 1.2 GB; 10^5: out of
// memory). More than this many is refused, as an InputError at the measurement file, so that
// the user crops or subsamples the data instead of waiting on a search that cannot finish.
inline constexpr int kMaxInterpretedPoints = 2000;

// Measurements are those of `set`; their labels are ignored.
Interpretation Interpret(const ConstraintGraph& graph, const MeasurementSet& set,
                         const InterpretOptions& options = {});

// The explored tree in Graphviz dot, like the paper's Figure 3.
std::string TreeDot(const ConstraintGraph& graph, const Interpretation& interpretation);

}  // namespace cfuse
