// Refinement: the best labelling re-associated against its own estimate, with proposals that
// move, shift or swap single matches; and the other interpretations as complete as the answer.
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>
#include <unordered_map>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/interp/closed_form_pose.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/combined_constraint.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/image_point.h"
#include "cfuse/kernel/measurements/point3.h"
#include "interpreter.h"

namespace cfuse::internal {

Solution Interpreter::SolveLabelling(const std::vector<int>& assignment,
                                     const Values& start) const {
  Solution solution = SolveFrom(assignment, &start);
  if (!solution.summary.converged) {
    // Gauss-Newton from the tree's estimate can still run away where an occluded point sits
    // only roughly placed; solve.h's closed-form starts are the fallback, and the better
    // of the two (converged, else the smaller constraint residual) is kept.
    Solution cold = SolveFrom(assignment, nullptr);
    if (cold.summary.converged ||
        cold.summary.max_constraint_residual < solution.summary.max_constraint_residual) {
      solution = std::move(cold);
    }
  }
  return solution;
}

Solution Interpreter::SolveFrom(const std::vector<int>& assignment, const Values* start) const {
  PoseSet guess;
  SolveOptions options = options_.solve;
  if (start) {
    for (const Component& c : g_.components) {
      const Block& b = g_.blocks[c.block];
      if (c.rigid) {
        guess.components.push_back({c.name, start->poses[b.index], {}});
      } else {
        guess.points.push_back({c.name, start->points[b.index], {}});
      }
    }
    options.guess = &guess;
    options.sequence.gauss_newton_from_start = true;
  }
  MeasurementSet labelled = set_;
  for (MeasuredPoint& m : labelled.points) m.label.clear();
  const Context& ctx = contexts_[best_context_];
  for (int l = 0; l < levels_; ++l) {
    if (assignment[l] >= 0) {
      labelled.points[assignment[l]].label =
          ModelPointName(g_, ctx.points[l].component, ctx.points[l].feature);
    }
  }
  return Solve(g_, labelled, options);
}

Solution Interpreter::Refine(std::vector<int>* assignment, int rounds, int* changes) const {
  Solution solution = SolveLabelling(*assignment, best_mean_);
  *changes = 0;
  // Scores under an estimate that did not converge mean nothing: the labelling stays.
  if (!solution.summary.converged) return solution;
  double score = LabellingScore(best_context_, *assignment, solution.state);
  // Each labelling is scored under its own estimate: the likelihood ratio of the data under
  // it against all clutter. A proposal replaces the labelling when it scores higher.
  // A proposal is also scored after one re-association under its own estimate: a label
  // moved to the right point frees the points it blocked (a segment matched twisted about
  // its long axis scores better only once its other corners follow).
  auto try_labelling = [&](const std::vector<int>& proposal) {
    std::vector<int> next = proposal;
    Solution next_solution = SolveLabelling(next, solution.state.mean);
    if (!next_solution.summary.converged) return false;
    double next_score = LabellingScore(best_context_, next, next_solution.state);
    if (std::vector<int> followed = Reassociate(best_context_, next_solution.state);
        followed != next) {
      Solution followed_solution = SolveLabelling(followed, next_solution.state.mean);
      const double followed_score =
          followed_solution.summary.converged
              ? LabellingScore(best_context_, followed, followed_solution.state)
              : -HUGE_VAL;
      if (followed_score > next_score) {
        next = std::move(followed);
        next_solution = std::move(followed_solution);
        next_score = followed_score;
      }
    }
    if (!(next_score > score)) return false;
    *assignment = next;
    solution = std::move(next_solution);
    score = next_score;
    ++*changes;
    return true;
  };
  for (int r = 0; r < rounds; ++r) {
    // Every point re-associated at once.
    const std::vector<int> next = Reassociate(best_context_, solution.state);
    if (next != *assignment && try_labelling(next)) continue;
    // A measurement moved from a matched point to an unmatched one whose gate holds it: two
    // points close together (the two faces of a thin plate) of which one is occluded. Matched
    // to the wrong one, the estimate bends to fit it, and re-association alone stays there.
    if (MoveToUnmatched(try_labelling, solution.state, *assignment)) continue;
    // A corner matched to its neighbour across a narrow part, the neighbour unmatched: the
    // estimate twists the part to fit, which keeps the corner's own measurement out of
    // every gate. The measurement moved to the neighbour, the part untwists and
    // re-association under it finds the corner.
    if (ShiftToUnmatched(try_labelling, solution.state, *assignment)) continue;
    // Image data: two matched points close together, each inside the other's gate (a thin
    // plate's two faces seen nearly edge-on): a labelling swapped there bends its estimate to
    // fit, and re-association under that estimate keeps it. Each such pair swapped, under
    // its own estimate. (In 3D such pairs are rare and the predictions cost 1.5 % of the
    // lamp's time.)
    if (!image_ || !SwapClosePairs(try_labelling, solution.state, *assignment)) break;
  }
  return solution;
}

template <typename Try>
bool Interpreter::SwapClosePairs(Try& try_labelling, const GaussianState& state,
                                 const std::vector<int>& assignment) const {
  const Context& ctx = contexts_[best_context_];
  std::vector<std::pair<Prediction, Prediction>> predicted(levels_);
  for (int l = 0; l < levels_; ++l) {
    if (assignment[l] >= 0) predicted[l] = PredictPoint(ctx.points[l], state);
  }
  auto inside = [&](int level, int m) {
    const auto& [p3, p2] = predicted[level];
    return Score(set_.points[m].is_3d ? p3 : p2, m).has_value();
  };
  bool changed = false;
  std::vector<int> current = assignment;
  for (int i = 0; i < levels_; ++i) {
    for (int j = i + 1; j < levels_; ++j) {
      const int mi = current[i], mj = current[j];
      if (mi < 0 || mj < 0 || !inside(i, mj) || !inside(j, mi)) continue;
      std::vector<int> next = current;
      std::swap(next[i], next[j]);
      if (try_labelling(next)) {
        current = std::move(next);
        changed = true;
      }
    }
  }
  return changed;
}

template <typename Try>
bool Interpreter::ShiftToUnmatched(Try& try_labelling, const GaussianState& state,
                                   const std::vector<int>& assignment) const {
  // 3D data only: in an image, points far apart in depth project close together, and such
  // shifts turned refusals into wrong answers (scissors from one camera: 2 more of 50).
  if (image_) return false;
  const Context& ctx = contexts_[best_context_];
  std::vector<Prediction> predicted(levels_);
  for (int l = 0; l < levels_; ++l) predicted[l] = PredictPoint(ctx.points[l], state).first;
  // (how near the measurement is to the unmatched point over the two points' distance,
  // unmatched level, matched level)
  std::vector<std::tuple<double, int, int>> shifts;
  for (int n = 0; n < levels_; ++n) {
    if (assignment[n] >= 0 || !predicted[n].valid) continue;
    for (int j = 0; j < levels_; ++j) {
      const int m = assignment[j];
      if (m < 0 || ctx.points[j].component != ctx.points[n].component) continue;
      if (!set_.points[m].is_3d || !predicted[j].valid) continue;
      const double apart = (predicted[n].mean - predicted[j].mean).norm();
      const double ratio = (set_.points[m].xyz - predicted[n].mean).norm() / apart;
      // Nearer the unmatched point than twice the two points' distance: it may be that
      // point's measurement, the estimate bent towards the other.
      if (ratio < 2) shifts.emplace_back(ratio, n, j);
    }
  }
  std::sort(shifts.begin(), shifts.end());
  if (shifts.size() > kMaxShifts) shifts.resize(kMaxShifts);
  for (const auto& [ratio, n, j] : shifts) {
    std::vector<int> next = assignment;
    next[n] = next[j];
    next[j] = -1;
    if (try_labelling(next)) return true;
  }
  return false;
}

template <typename Try>
bool Interpreter::MoveToUnmatched(Try& try_labelling, const GaussianState& state,
                                  const std::vector<int>& assignment) const {
  const Context& ctx = contexts_[best_context_];
  for (int n = 0; n < levels_; ++n) {
    if (assignment[n] >= 0) continue;
    const auto [p3, p2] = PredictPoint(ctx.points[n], state);
    for (int j = 0; j < levels_; ++j) {
      const int m = assignment[j];
      if (m < 0 || !Score(set_.points[m].is_3d ? p3 : p2, m)) continue;
      std::vector<int> next = assignment;
      next[n] = m;
      next[j] = -1;
      if (try_labelling(next)) return true;
    }
  }
  return false;
}

std::vector<Interpreter::Found> Interpreter::Alternatives(const GaussianState& answer,
                                                          int max_seeds) {
  std::vector<Found> out;
  if (best_matched_ < 0 || seeds_.empty()) return out;
  const int need = best_matched_;
  const int saved_context = best_context_, saved_support = best_seed_support_;
  const double saved_delta = best_delta_;
  const std::vector<int> saved_assignment = best_assignment_;
  const Values saved_mean = best_mean_;
  const auto saved_trace = best_trace_;
  const int saved_predicted = best_predicted_;
  const SearchStats::Status saved_status = stats_.status;
  stats_.status = SearchStats::Status::kComplete;  // the searches below set it anew
  std::vector<GaussianState> placed = {answer};    // the answer's and each alternative's
  // Whether the seed puts its own points where one of `placed` has them.
  auto known = [&](const Seed& seed) {
    const Context& ctx = contexts_[seed.context];
    return std::any_of(placed.begin(), placed.end(), [&](const GaussianState& state) {
      for (const auto& [level, m] : seed.assignment) {
        const Eigen::Vector3d seeded = seed.world_from_nominal * ctx.nominal[level];
        const Eigen::Vector3d there =
            ModelPoint(g_, state.mean, ctx.points[level].component, ctx.points[level].feature);
        if ((there - seeded).norm() > 0.05 * extent_) {
          return false;
        }
      }
      return true;
    });
  };
  std::vector<size_t> order(seeds_.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return seeds_[a].support > seeds_[b].support; });
  int tried = 0;
  for (size_t i : order) {
    if (tried >= max_seeds || seeds_[i].support + kSupportMargin < saved_support) break;
    // A seed searched while a better interpretation stood was asked for more matches than
    // `need`, and may hold one with as many; one searched before found fewer.
    const bool asked_more = i < searched_beyond_.size() && searched_beyond_[i] >= need;
    if ((searched_[i] && !asked_more) || known(seeds_[i])) continue;
    // Within what is left of the budget (none after a search the budget ended); a seed's own
    // matches are fused before the search can stop on it.
    if (stats_.nodes + static_cast<long>(seeds_[i].assignment.size()) >= options_.max_nodes) {
      break;
    }
    searched_[i] = true;
    ++tried;
    best_matched_ = need - 1;  // the search below takes only labellings matching `need`
    found_ = false;
    Search(&seeds_[i]);
    if (stats_.status == SearchStats::Status::kBudget) break;
    if (!found_) continue;
    Solution alternative = SolveLabelling(best_assignment_, best_mean_);
    if (!alternative.accepted()) continue;
    if (!Distinct(g_, alternative.state.mean, answer, extent_)) continue;
    placed.push_back(alternative.state);
    out.push_back({std::move(alternative), best_context_ == saved_context, best_assignment_});
  }
  best_matched_ = need;
  best_context_ = saved_context;
  best_seed_support_ = saved_support;
  best_delta_ = saved_delta;
  best_assignment_ = saved_assignment;
  best_mean_ = saved_mean;
  best_trace_ = saved_trace;
  best_predicted_ = saved_predicted;
  stats_.status = saved_status;
  return out;
}

std::vector<Interpreter::Found> Interpreter::SymmetricAlternatives(
    const Solution& answer, const std::vector<int>& assignment, int max_readings) const {
  std::vector<Found> out;
  if (!symmetries_.any()) return out;
  const Context& ctx = contexts_[best_context_];
  std::map<std::pair<int, int>, int> level_of;
  for (int l = 0; l < levels_; ++l) {
    level_of[{ctx.points[l].component, ctx.points[l].feature}] = l;
  }
  const double tolerance = 0.02 * std::max(extent_, 1.0);
  for (const Reading& reading : symmetries_.Find(answer.state.mean, tolerance, max_readings)) {
    std::vector<int> next(levels_, -1);
    for (int l = 0; l < levels_; ++l) {
      const ModelPointRef p = ctx.points[l];
      const int source = reading.source_component[p.component];
      const int feature = g_.components[p.component].rigid
                              ? reading.source_point[p.component][p.feature]
                              : p.feature;
      const auto it = level_of.find({source, feature});
      if (it != level_of.end()) next[l] = assignment[it->second];
    }
    Solution solution = SolveLabelling(next, reading.mean);
    if (!solution.accepted() || !Distinct(g_, solution.state.mean, answer.state, extent_)) {
      continue;
    }
    out.push_back({std::move(solution), true, std::move(next)});
  }
  return out;
}

std::vector<int> Interpreter::Reassociate(int context, const GaussianState& state) const {
  struct Pair {
    double score;
    int level, measurement;
  };
  std::vector<Pair> pairs;
  const Context& ctx = contexts_[context];
  for (int l = 0; l < levels_; ++l) {
    const auto [p3, p2] = PredictPoint(ctx.points[l], state);
    for (size_t m = 0; m < set_.points.size(); ++m) {
      if (duplicate_[m]) continue;
      const std::optional<Candidate> c = Score(set_.points[m].is_3d ? p3 : p2, static_cast<int>(m));
      if (c && c->log_ratio > 0) pairs.push_back({c->log_ratio, l, static_cast<int>(m)});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return a.score > b.score || (a.score == b.score && std::tie(a.level, a.measurement) <
                                                           std::tie(b.level, b.measurement));
  });
  std::vector<int> assignment(levels_, -1);
  std::vector<bool> taken(set_.points.size(), false);
  for (const Pair& p : pairs) {
    if (assignment[p.level] >= 0 || taken[p.measurement]) continue;
    assignment[p.level] = p.measurement;
    taken[p.measurement] = true;
  }
  return assignment;
}

}  // namespace cfuse::internal
