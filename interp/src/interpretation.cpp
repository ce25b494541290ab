#include "cfuse/interp/interpretation.h"

#include <fmt/format.h>

#include <algorithm>
#include <optional>

#include "cfuse/kernel/check.h"
#include "interpreter.h"
#include "solve_internal.h"

namespace cfuse {

using internal::Interpreter;

const char* StatusName(SearchStats::Status status) {
  switch (status) {
    case SearchStats::Status::kComplete:
      return "complete";
    case SearchStats::Status::kBudget:
      return "node budget exhausted";
  }
  return "?";
}

FusionPlan PlanCache::Plan(bool image, const PlanStart* start,
                           const std::function<FusionPlan()>& make) const {
  auto key = std::make_tuple(image, start ? start->components : std::vector<int>{-1},
                             start ? start->features : std::vector<int>{});
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = plans_.find(key); it != plans_.end()) return it->second;
  }
  FusionPlan plan = make();
  std::lock_guard<std::mutex> lock(mutex_);
  return plans_.emplace(std::move(key), std::move(plan)).first->second;
}

std::vector<std::array<int, 3>> PlanCache::Triangles(
    bool between_components, const std::function<std::vector<std::array<int, 3>>()>& make) const {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = triangles_.find(between_components); it != triangles_.end()) return it->second;
  }
  std::vector<std::array<int, 3>> triangles = make();
  std::lock_guard<std::mutex> lock(mutex_);
  return triangles_.emplace(between_components, std::move(triangles)).first->second;
}

Interpretation Interpret(const ConstraintGraph& graph, const MeasurementSet& set,
                         const InterpretOptions& options) {
  CheckGraph(graph);
  CheckMeasurementSet(set);
  RequireEstimable(graph);
  // Labels do not steer the search, but a label naming no model point is a mistake in the file.
  ResolveLabels(graph, set);
  if (set.points.size() > static_cast<size_t>(kMaxInterpretedPoints)) {
    throw InputError(SourceLocation(set.source),
                     fmt::format("{} measurements: interpretation takes at most {} (its time and "
                                 "memory grow with their square); crop or subsample the data",
                                 set.points.size(), kMaxInterpretedPoints));
  }
  Interpretation out;
  std::vector<bool> use(graph.constraints.size(), true);
  if (!options.use_constraints_between_components) {
    for (size_t k = 0; k < graph.constraints.size(); ++k) {
      use[k] = ConstraintComponents(graph, graph.constraints[k]).size() <= 1;
    }
  }
  Interpreter search(graph, set, options, use);
  search.Run();
  out.plan = search.best_plan();
  out.stats = search.stats_;
  out.stats.levels = static_cast<int>(out.plan.levels.size());
  out.matches.assign(set.points.size(), "");
  out.assignment.assign(out.plan.levels.size(), -1);
  if (search.best_matched_ < 0) return out;
  out.assignment = search.best_assignment_;
  out.total_delta = search.best_delta_;
  std::optional<Solution> solution;
  // Not for a branch the budget cut short: its estimate, from a few matches, would re-associate
  // the rest to clutter (lamps at 30 % occlusion: 59 % of matches right without, 11 % with).
  if (options.refine_rounds > 0 && search.complete_) {
    solution = search.Refine(&out.assignment, options.refine_rounds, &out.stats.refinements);
  }
  // The matches, and each level's choice in the trace, from the assignment.
  auto record = [&] {
    out.matches.assign(set.points.size(), "");
    out.matched = 0;
    for (size_t l = 0; l < out.plan.levels.size(); ++l) {
      const PlanLevel& p = out.plan.levels[l];
      out.trace[l].chosen = out.assignment[l];
      if (out.assignment[l] >= 0) {
        out.matches[out.assignment[l]] = ModelPointName(graph, p.component, p.feature);
        ++out.matched;
      }
    }
  };
  for (size_t l = 0; l < out.plan.levels.size(); ++l) {
    const PlanLevel& p = out.plan.levels[l];
    TraceLevel t;
    t.constraints = p.constraints;
    t.component = p.component;
    t.feature = p.feature;
    t.best = search.best_trace_[l];
    out.trace.push_back(std::move(t));
  }
  record();
  if (out.matched > 0) {
    out.solution =
        solution ? std::move(solution) : search.SolveLabelling(out.assignment, search.best_mean_);
    // From one image the answer's labelling can have several minima, and a fit the test accepts
    // only just may be the wrong one (the hinged box's lid 25 degrees off at p = 0.02, its own
    // minimum from the tree's estimate): the labelling is solved again from solve's closed-form
    // starts, their flips and, the fit being poor, each joint swept (solve.h's exploration, which
    // a solve from a guess skips). Once, for the answer: inside every solve of the search it cost
    // a fifth more time.
    const SolveOptions& so = options.solve;
    if (search.image() && so.explore_starts &&
        out.solution->analysis.fit.p_value < so.explore_p_value) {
      Solution cold = search.SolveFrom(out.assignment, nullptr);
      if (internal::Sound(cold) &&
          cold.analysis.fit.chi2 < out.solution->analysis.fit.chi2 - 0.01) {
        *out.solution = std::move(cold);
      }
    }
    // An answer the fit test rejects can be a reading of the right one that the data only
    // nearly allow (a folding ruler read from its other end, each segment turned end for end
    // with its corners 3 mm off): the best accepted reading replaces it.
    if (!out.solution->accepted() && options.max_symmetric_readings > 0) {
      std::vector<Interpreter::Found> readings = search.SymmetricAlternatives(
          *out.solution, out.assignment, options.max_symmetric_readings);
      const auto best =
          std::min_element(readings.begin(), readings.end(), [](const auto& a, const auto& b) {
            return a.solution.analysis.fit.chi2 < b.solution.analysis.fit.chi2;
          });
      if (best != readings.end()) {
        // Re-associated under its own estimate: points the wrong reading left unmatched can
        // find their measurements now.
        std::vector<int> assignment = best->assignment;
        if (options.refine_rounds > 0) {
          search.best_mean_ = best->solution.state.mean;
          int changes = 0;
          Solution refined = search.Refine(&assignment, options.refine_rounds, &changes);
          if (refined.accepted()) {
            best->solution = std::move(refined);
            best->assignment = std::move(assignment);
            out.stats.refinements += changes;
          }
        }
        *out.solution = std::move(best->solution);
        out.assignment = std::move(best->assignment);
        record();
      }
    }
    if (out.solution->accepted() &&
        (options.max_alternative_seeds > 0 || options.max_symmetric_readings > 0)) {
      std::vector<Interpreter::Found> others =
          search.Alternatives(out.solution->state, options.max_alternative_seeds);
      for (Interpreter::Found& other : search.SymmetricAlternatives(
               *out.solution, out.assignment, options.max_symmetric_readings)) {
        others.push_back(std::move(other));
      }
      // One that matches as many points in the same plan and fits better is the answer: the
      // data tell them apart (a folding ruler read from its other end fits, but worse).
      bool replaced = false;
      for (Interpreter::Found& other : others) {
        // (By more than rounding: an exact symmetry's reading fits the same.)
        const double chi2 = out.solution->analysis.fit.chi2;
        if (other.same_plan && other.solution.analysis.fit.chi2 < chi2 - 1e-9 * (1 + chi2)) {
          Solution previous = std::move(*out.solution);
          *out.solution = std::move(other.solution);
          other.solution = std::move(previous);
          std::swap(out.assignment, other.assignment);
          record();
          replaced = true;
        }
      }
      // Refined under its own estimate, as a reading of a rejected answer is above: a reading
      // carries the labels the search gave points only nearly where it puts them (a ruler read
      // from its other end, a segment's corner on the next segment's), and each may have a
      // point of its own now.
      if (replaced && options.refine_rounds > 0) {
        std::vector<int> assignment = out.assignment;
        search.best_mean_ = out.solution->state.mean;
        int changes = 0;
        Solution refined = search.Refine(&assignment, options.refine_rounds, &changes);
        if (changes > 0 && refined.accepted()) {
          *out.solution = std::move(refined);
          out.assignment = std::move(assignment);
          out.stats.refinements += changes;
          record();
        }
      }
      // Each distinct answer once: a reading of the answer can repeat what a seed found.
      std::vector<const GaussianState*> listed = {&out.solution->state};
      const double extent = ModelExtent(graph);
      for (const Interpreter::Found& other : others) {
        const bool seen = std::any_of(listed.begin(), listed.end(), [&](const GaussianState* s) {
          return !Distinct(graph, other.solution.state.mean, *s, extent);
        });
        if (seen) continue;
        listed.push_back(&other.solution.state);
        out.solution->alternatives.push_back(
            {other.solution.state.mean, other.solution.analysis.fit});
      }
      // The statistics count the search for alternatives too.
      const int refinements = out.stats.refinements;
      out.stats = search.stats_;
      out.stats.levels = static_cast<int>(out.plan.levels.size());
      out.stats.refinements = refinements;
    }
  }
  out.stats.predicted = search.image() ? search.best_predicted_ : -1;
  return out;
}

std::string Interpretation::Refusal() const {
  if (!solution) return "no measurement matches a model point";
  if (!solution->accepted()) return "the estimate from the matches is not accepted";
  // A search the budget cut short has not compared its best with the rest: unless that best
  // accounts for all model points but internal::kLazyNulls (where a complete search stops too), a
  // better interpretation may lie in what it did not see.
  if (stats.status == SearchStats::Status::kBudget &&
      matched < static_cast<int>(assignment.size()) - internal::kLazyNulls) {
    return fmt::format(
        "the node budget ended the search with {} of {} model points matched: "
        "the best interpretation so far is written, unverified (raise "
        "--max-nodes, or crop the data)",
        matched, assignment.size());
  }
  if (!solution->undetermined.empty()) {
    std::string names;
    for (const std::string& n : solution->undetermined) names += (names.empty() ? "" : ", ") + n;
    return fmt::format(
        "the {} matches leave {} undetermined: too few to tell the object from "
        "clutter",
        matched, names);
  }
  if (solution->analysis.fit.dof < 1) {
    return fmt::format(
        "the {} matches fit exactly, with no residual degrees of freedom: any {} "
        "points would, so they cannot tell the object from clutter",
        matched, matched);
  }
  // From an image, the first matches fix the pose and any clutter fits them; only a match
  // predicted where clutter is unlikely is evidence. The scissors among as many clutter
  // points were accepted with 4 or 5 matches, 0 to 2 of them predicted, every one wrong (0.1 to
  // 0.6 m off); right answers had at least 4 (bench/answer_sweep).
  if (stats.predicted >= 0 && stats.predicted < internal::kMinPredicted) {
    return fmt::format(
        "only {} of the {} matches were predicted before they were seen (the "
        "others fix the pose, and clutter would fit them as well): too few to "
        "tell the object from clutter",
        stats.predicted, matched);
  }
  return "";
}

}  // namespace cfuse
