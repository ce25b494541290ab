// The tree: depth-first below a seed in rounds of iterative deepening on null branches, fusing
// each level's constraints (Hel-Or & Werman) and placing or postponing points that nothing
// predicts.
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

void Interpreter::Search(const Seed* seed) {
  context_ = seed ? seed->context : 0;
  ctx_ = &contexts_[context_];
  Values initial = g_.nominal;
  if (seed) {
    for (Eigen::Vector3d& p : initial.points) p = seed->world_from_nominal * p;
    for (size_t c = 0; c < g_.components.size(); ++c) {
      const Block& b = g_.blocks[g_.components[c].block];
      if (b.kind == BlockKind::kPose) {
        const Rigid3d& motion =
            seed->placement.empty() ? seed->world_from_nominal : seed->placement[c];
        initial.poses[b.index] = motion * g_.nominal.poses[b.index];
      }
    }
    // A component the sweep placed has moved its joint: an inequality's slack kept at its
    // nominal value contradicts the placement (the scissors' opening placed at its limit,
    // the slack still saying 25 degrees), and its first fusion pulls the component back.
    MatchSlacks(g_, &initial);
  }
  PriorScale scale;
  scale.position = options_.solve.prior_extent_factor * extent_;
  scale.rotation = options_.solve.prior_rotation_sigma;
  scale.slack = options_.solve.prior_slack_sigma;
  Frame root;
  root.state = MakePrior(g_.blocks, initial, scale);
  root.null_component.assign(g_.components.size(), false);
  root.tried.assign(g_.components.size(), 0);
  root.done.assign(levels_, 0);
  root.revisit.assign(levels_, 0);
  for (int l = 1; l < levels_; ++l) root.pending.push_back(l);
  preassigned_.assign(levels_, -1);
  assignment_.assign(levels_, -1);
  if (seed) {
    // The seed's matches, fused first; their levels take no other branch.
    for (const auto& [level, m] : seed->assignment) {
      preassigned_[level] = m;
      ++stats_.nodes;
      const Factor f = MeasurementFactor(g_, set_, ctx_->points[level], m, !set_.points[m].is_3d);
      if (!Fuse(f, &root.state).changed_state()) {
        ++stats_.backtracks;
        return;
      }
    }
  }
  if (!EnterLevel(&root)) {
    ++stats_.backtracks;
    return;
  }
  // Iterative deepening on null branches without repeating a round's work: round k resumes
  // only the null branches round k-1 could not take (each saved with its frame), since every
  // other branch below them was searched then. When too many are waiting to be kept, the next
  // round searches again from the root.
  std::vector<Resume> roots(1);
  roots[0].frame = root;
  roots[0].assignment = assignment_;
  for (int nulls = 0; nulls <= levels_ && !found_ && !roots.empty(); ++nulls) {
    if (best_matched_ >= 0 && levels_ - nulls <= best_matched_) break;
    max_nulls_ = nulls;
    waiting_.clear();
    overflow_ = false;
    for (Resume& r : roots) {
      SearchBelow(std::move(r));
      if (found_ || stats_.status == SearchStats::Status::kBudget) return;
    }
    if (overflow_) {
      roots.assign(1, Resume{root, {}, std::vector<int>(levels_, -1)});
    } else {
      roots = std::move(waiting_);
    }
    waiting_.clear();
  }
}

void Interpreter::SearchBelow(Resume r) {
  assignment_ = r.assignment;
  trace_prefix_ = std::move(r.trace);
  std::vector<Frame> stack;
  stack.push_back(std::move(r.frame));
  while (!stack.empty()) {
    Frame& f = stack.back();
    if (f.next == f.candidates.size()) {
      stack.pop_back();
      continue;
    }
    const Candidate c = f.candidates[f.next++];
    const int real = c.measurement >= 0 ? 1 : 0;
    // A blind point's first null only postpones it: not counted.
    const bool postpone = f.blind && !f.revisit[f.level];
    // Single points only: a rigid component's features stand or fall with its pose, and a
    // free null would hide the one feature that shows a pose wrong (the box's lid faces).
    const bool free_null = !real && f.evidenced_null &&
                           f.free_nulls < options_.free_evidenced_nulls &&
                           !g_.components[ctx_->points[f.level].component].rigid;
    // The null branch after a confident match passed its tests is not tried: the point is
    // there (Lowe's probability that the measurement is clutter is below 1 %). Its other
    // candidates still are: pruned too, the hinged box lost 1.5-2 % of its trials.
    if (!real && !postpone && options_.probability_order && f.confident_passed) continue;
    if (!real && !postpone && !free_null && f.nulls >= max_nulls_) {
      // For the next round, unless too many wait already.
      if (waiting_.size() >= kMaxWaiting) {
        overflow_ = true;
      } else if (!overflow_) {
        Resume w{f, trace_prefix_, assignment_};
        w.frame.candidates = {c};
        w.frame.next = 0;
        for (const Frame& above : stack) {
          if (&above != &f) w.trace.push_back({above.level, above.best3});
        }
        waiting_.push_back(std::move(w));
      }
      continue;
    }
    // Can this branch still match more points than the best so far?
    const int can_match = f.matched + real + static_cast<int>(f.pending.size());
    if (best_matched_ >= 0 && can_match <= best_matched_) continue;
    if (stats_.nodes >= options_.max_nodes) {
      stats_.status = SearchStats::Status::kBudget;
      return;
    }
    ++stats_.nodes;
    Frame child;
    child.done = f.done;
    child.revisit = f.revisit;
    child.pending = f.pending;
    if (postpone) {
      child.pending.push_back(f.level);  // postponed to the end of the branch
      child.revisit[f.level] = 1;
    } else {
      child.done[f.level] = 1;
    }
    const bool leaf = child.pending.empty();
    if (!leaf) {
      child.level = child.pending.front();
      child.pending.erase(child.pending.begin());
    }
    child.state = f.state;
    child.matched = f.matched + real;
    child.nulls = f.nulls + (real || postpone || free_null ? 0 : 1);
    child.free_nulls = f.free_nulls + (free_null ? 1 : 0);
    child.nis_sum = f.nis_sum;
    child.nis_dof = f.nis_dof;
    child.null_component = f.null_component;
    child.tried = f.tried;
    child.deferred = f.deferred;
    assignment_[f.level] = c.measurement;
    const int component = ctx_->points[f.level].component;
    if (!real && !g_.components[component].rigid) child.null_component[component] = true;
    if (real && f.revisit[f.level]) {
      // A postponed point matched: its constraints waiting on it are its own now.
      child.null_component[component] = false;
      for (int k : f.own)
        child.deferred.erase(std::find(child.deferred.begin(), child.deferred.end(), k));
    }
    double delta = 0;  // the match's: its own NIS and that of the constraints placing it
    if (real && preassigned_[f.level] < 0) {
      const bool image = !set_.points[c.measurement].is_3d;
      const Factor factor =
          MeasurementFactor(g_, set_, ctx_->points[f.level], c.measurement, image);
      const FusionSummary s = Fuse(factor, &child.state);
      if (!s.changed_state()) {
        ++stats_.backtracks;
        continue;
      }
      delta += s.final_nis;
      child.nis_sum += s.final_nis;
      child.nis_dof += image ? 2 : 3;
    }
    double own_nis = 0;
    if (!FuseConstraints(f.own, &child, &own_nis) || !FuseDeferred(&child)) {
      ++stats_.backtracks;
      continue;
    }
    // A match is scored by its own innovation and by how far the constraints placing it had
    // to move (both vanish for a perfect match); the null branch scores 0.
    if (real) delta += own_nis;
    child.delta_sum = f.delta_sum + delta;
    if (!JointlyCompatible(child) || (real && delta > f.gate)) {
      ++stats_.backtracks;
      continue;
    }
    ++stats_.expanded;
    if (real && c.probability >= kConfident) f.confident_passed = true;
    if (leaf) {
      double trailing_nis = 0;
      if (FuseConstraints(ctx_->plan.trailing, &child, &trailing_nis) && FuseRemaining(&child) &&
          JointlyCompatible(child)) {
        Leaf(child, stack);
        return;  // the first complete interpretation of the round
      } else {
        ++stats_.backtracks;
      }
      continue;
    }
    if (!EnterLevel(&child)) {
      ++stats_.backtracks;
      continue;
    }
    if (best_matched_ < 0 && child.matched > partial_.matched) {
      // The best branch so far, for when the budget ends the search before any leaf.
      partial_.matched = child.matched;
      partial_.context = context_;
      partial_.support = seed_support_;
      partial_.assignment.assign(levels_, -1);
      for (int l = 0; l < levels_; ++l) {
        partial_.assignment[l] = preassigned_[l] >= 0 ? preassigned_[l]
                                 : child.done[l]      ? assignment_[l]
                                                      : -1;
      }
      partial_.mean = child.state.mean;
    }
    stack.push_back(std::move(child));
  }
}

bool Interpreter::FuseConstraints(const std::vector<int>& list, Frame* f, double* nis) const {
  for (int k : list) {
    if (!use_[k]) continue;
    const std::vector<int>& comps = constraint_components_[k];
    if (std::any_of(comps.begin(), comps.end(), [&](int c) { return f->null_component[c]; })) {
      f->deferred.push_back(k);
      continue;
    }
    const Constraint& c = g_.constraints[k];
    if (!Accept(Fuse({c.residual, c.blocks, {}, c.name}, &f->state), f, nis)) return false;
  }
  return true;
}

bool Interpreter::Accept(const FusionSummary& s, Frame* f, double* nis) const {
  if (s.status == FusionSummary::Status::kContradiction ||
      s.status == FusionSummary::Status::kInvalid ||
      s.status == FusionSummary::Status::kNotConverged) {
    return false;
  }
  if (s.rows_fused > 0) {
    if (s.final_nis > Gate(s.rows_fused)) return false;
    f->nis_sum += s.final_nis;
    f->nis_dof += s.rows_fused;
    *nis += s.final_nis;
  }
  return true;
}

bool Interpreter::FuseDeferred(Frame* f) const {
  if (f->deferred.empty()) return true;
  for (size_t n = 0; n < g_.components.size(); ++n) {
    if (!f->null_component[n]) continue;
    std::vector<int> ready;
    for (int k : f->deferred) {
      const std::vector<int>& comps = constraint_components_[k];
      if (std::find(comps.begin(), comps.end(), static_cast<int>(n)) == comps.end()) continue;
      // Its other points matched, or occluded and placed already.
      const bool others_known = std::all_of(comps.begin(), comps.end(), [&](int c) {
        return c == static_cast<int>(n) || !f->null_component[c];
      });
      if (others_known) ready.push_back(k);
    }
    // Tried once per set of ready constraints: the attempt below fails the same way until
    // another neighbour is matched.
    if (static_cast<int>(ready.size()) <= f->tried[n]) continue;
    f->tried[n] = static_cast<int>(ready.size());
    Eigen::Vector3d& point = f->state.mean.points[g_.blocks[g_.components[n].block].index];
    const Eigen::Vector3d guessed = point;
    if (!Recentre(f, static_cast<int>(n)) || !Determine(ready, static_cast<int>(n), *f) ||
        !Place(ready, static_cast<int>(n), f)) {
      point = guessed;
      continue;
    }
    GaussianState saved = f->state;
    // Together: fused one by one, a constraint linearised at the re-centred guess can leave
    // the next one degenerate (combined_constraint.h).
    std::vector<Factor> parts;
    for (int k : ready) {
      const Constraint& c = g_.constraints[k];
      parts.push_back({c.residual, c.blocks, {}, c.name});
    }
    const Factor joint = parts.size() == 1
                             ? parts[0]
                             : CombinedConstraint(parts, block_kinds_, ModelPointName(g_, n, -1));
    const FusionSummary s = Fuse(joint, &f->state, joint_fusion_);
    if (s.status == FusionSummary::Status::kNotConverged) {
      // The neighbours matched so far place the point only ill-conditioned (it sits where
      // their spheres touch): it waits for more of them.
      f->state = std::move(saved);
      f->state.mean.points[g_.blocks[g_.components[n].block].index] = guessed;
      continue;
    }
    double nis = 0;
    if (!Accept(s, f, &nis)) return false;
    f->null_component[n] = false;  // placed: its constraints are fused from now on
    for (int k : ready) f->deferred.erase(std::find(f->deferred.begin(), f->deferred.end(), k));
  }
  return true;
}

bool Interpreter::FuseRemaining(Frame* f) const {
  if (f->deferred.empty()) return true;
  for (size_t n = 0; n < g_.components.size(); ++n) {
    if (!f->null_component[n] || !Recentre(f, static_cast<int>(n))) continue;
    std::vector<int> own;
    for (int k : f->deferred) {
      const std::vector<int>& comps = constraint_components_[k];
      if (std::find(comps.begin(), comps.end(), static_cast<int>(n)) != comps.end()) {
        own.push_back(k);
      }
    }
    Place(own, static_cast<int>(n), f);
  }
  std::vector<Factor> parts;
  for (int k : f->deferred) {
    const Constraint& c = g_.constraints[k];
    parts.push_back({c.residual, c.blocks, {}, c.name});
  }
  f->deferred.clear();
  double nis = 0;
  GaussianState saved = f->state;
  const FusionSummary s =
      Fuse(CombinedConstraint(parts, block_kinds_, "deferred"), &f->state, joint_fusion_);
  if (s.status == FusionSummary::Status::kNotConverged) {
    // The points stay determined only at second order (see Determine): their iterations do
    // not settle, but the first, linearised where the points were guessed, still tests the
    // matches.
    f->state = std::move(saved);
    return s.rows_fused == 0 || s.innovation_nis <= Gate(s.rows_fused);
  }
  return Accept(s, f, &nis);
}

bool Interpreter::Place(const std::vector<int>& list, int component, Frame* f) const {
  return PlacePoint(g_, list, g_.components[component].block, &f->state.mean,
                    {.max_iterations = kPlaceIterations});
}

bool Interpreter::Determine(const std::vector<int>& list, int component, const Frame& f) const {
  const int point_block = g_.components[component].block;
  std::vector<Eigen::RowVector3d> rows;
  Eigen::VectorXd r;
  Eigen::MatrixXd H;
  for (int k : list) {
    const Constraint& c = g_.constraints[k];
    EvaluateResidual(*c.residual, g_.blocks, c.blocks, f.state.mean, &r, &H);
    int column = 0;
    for (int b : c.blocks) {
      if (b == point_block) {
        for (int i = 0; i < H.rows(); ++i) {
          const Eigen::RowVector3d row = H.block<1, 3>(i, column);
          if (row.norm() > 0) rows.push_back(row.normalized());
        }
      }
      column += TangentDim(g_.blocks[b].kind);
    }
  }
  if (rows.size() < 3) return false;
  // The smallest singular value of the stacked rows is the root of the smallest eigenvalue
  // of their 3 x 3 Gram matrix (0.1 is far above where forming it loses precision).
  Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
  for (const Eigen::RowVector3d& row : rows) gram.noalias() += row.transpose() * row;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(gram, Eigen::EigenvaluesOnly);
  return eigen.eigenvalues()(0) > kDetermined * kDetermined;
}

bool Interpreter::IsMatched(const Frame& f, int c) const {
  for (int l = 0; l < levels_; ++l) {
    if (ctx_->points[l].component != c) continue;
    if (preassigned_[l] >= 0 || (f.done[l] && assignment_[l] >= 0)) return true;
  }
  return false;
}

bool Interpreter::EnterLevel(Frame* f) const {
  const int level = f->level;
  const int component = ctx_->points[level].component;
  f->own.clear();
  std::vector<int> pre;
  if (!f->revisit[level]) {
    for (int k : ctx_->plan.levels[level].constraints) {
      if (!use_[k]) continue;
      const std::vector<int>& comps = constraint_components_[k];
      (std::find(comps.begin(), comps.end(), component) != comps.end() ? f->own : pre).push_back(k);
    }
    f->gate = ctx_->level_gate[level];
  } else {
    // A postponed point: its own constraints are those still waiting on it alone.
    int rows = image_ ? 2 : 3;
    for (int k : f->deferred) {
      const std::vector<int>& comps = constraint_components_[k];
      if (std::find(comps.begin(), comps.end(), component) == comps.end()) continue;
      if (std::any_of(comps.begin(), comps.end(),
                      [&](int c) { return c != component && f->null_component[c]; })) {
        continue;
      }
      f->own.push_back(k);
      rows += g_.constraints[k].residual->dimension();
    }
    f->gate = Gate(rows);
  }
  double nis = 0;
  if (!FuseConstraints(pre, f, &nis)) return false;
  Recentre(f, component);
  BuildCandidates(f);
  return true;
}

bool Interpreter::Recentre(Frame* f, int component) const {
  GaussianState& state = f->state;
  const int block = g_.components[component].block;
  std::vector<int> group;
  if (state.groups.num_blocks() == static_cast<int>(g_.blocks.size())) {
    state.groups.Support(std::vector<int>{block}, &group);
    if (group.size() > 1) return false;
  }
  std::vector<bool> matched(g_.components.size(), false);
  for (size_t c = 0; c < g_.components.size(); ++c) {
    matched[c] = IsMatched(*f, static_cast<int>(c));
  }
  std::vector<Eigen::Vector3d> from, to;
  std::optional<Rigid3d> motion;
  for (size_t k = 0; k < g_.constraints.size() && !motion; ++k) {
    const std::vector<int>& comps = constraint_components_[k];
    if (!use_[k] || std::find(comps.begin(), comps.end(), component) == comps.end()) continue;
    for (int n : comps) {
      if (n == component || !matched[n]) continue;
      const Component& c = g_.components[n];
      const Block& b = g_.blocks[c.block];
      if (c.rigid) {
        motion = state.mean.poses[b.index] * g_.nominal.poses[b.index].Inverse();
        break;
      }
      if (std::find(to.begin(), to.end(), state.mean.points[b.index]) == to.end()) {
        from.push_back(g_.nominal.points[b.index]);
        to.push_back(state.mean.points[b.index]);
      }
    }
  }
  if (!motion) {
    Rigid3d fit;
    if (!AbsoluteOrientation(from, to, &fit)) return false;
    motion = fit;
  }
  const Block& b = g_.blocks[block];
  if (g_.components[component].rigid) {
    state.mean.poses[b.index] = *motion * g_.nominal.poses[b.index];
  } else {
    state.mean.points[b.index] = *motion * g_.nominal.points[b.index];
  }
  return true;
}

void Interpreter::BuildCandidates(Frame* f) const {
  const int level = f->level;
  f->candidates.clear();
  f->best3.clear();
  f->blind = false;
  if (preassigned_[level] >= 0) {
    f->candidates = {{preassigned_[level], 0, 1, true}};
    f->best3 = {{preassigned_[level], 0}};
    return;
  }
  if (options_.postpone_blind &&
      (f->revisit[level] ? f->null_component[ctx_->points[level].component] && f->own.empty()
                         : Blind(*f))) {
    // Every measurement would pass its gate and no constraint could test it: a branch per
    // measurement, each searched below, for a point that predicts nothing. It is taken as
    // unmatched here, placed once its neighbours are (FuseDeferred), and re-associated under
    // the interpretation's estimate (Refine).
    f->blind = true;
    f->candidates = {Candidate{-1, 0, 0, true}};
    return;
  }
  std::vector<bool> used = duplicate_;
  for (int l = 0; l < levels_; ++l) {
    if (preassigned_[l] >= 0) used[preassigned_[l]] = true;
    if (f->done[l] && assignment_[l] >= 0) used[assignment_[l]] = true;
  }
  // (A): the linear prediction.
  const auto [p3, p2] = PredictWithOwn(*f, ctx_->points[level]);
  std::vector<bool> listed(set_.points.size(), false);
  for (size_t m = 0; m < set_.points.size(); ++m) {
    if (used[m]) continue;
    const MeasuredPoint& z = set_.points[m];
    const std::optional<Candidate> scored = Score(z.is_3d ? p3 : p2, static_cast<int>(m));
    if (!scored) continue;
    f->candidates.push_back(*scored);
    listed[m] = true;
  }
  std::vector<Candidate>& c = f->candidates;
  std::sort(c.begin(), c.end(), [](const Candidate& a, const Candidate& b) {
    return a.delta < b.delta || (a.delta == b.delta && a.measurement < b.measurement);
  });
  if (options_.probability_order) {
    std::stable_sort(c.begin(), c.end(), [](const Candidate& a, const Candidate& b) {
      return a.probability > b.probability;
    });
  }
  // (B): the exact locus of a single point's own constraints; not needed where a candidate
  // is confident (p/(p+q) >= kConfident under a prediction that says something): the
  // linearisation the locus corrects is then good.
  const bool confident = options_.probability_order && !c.empty() && c[0].informative &&
                         c[0].probability >= kConfident;
  std::vector<Candidate> locus;
  if (!confident) locus = LocusCandidates(*f, used, listed);
  // The null branch: last (the paper), or before the first candidate more likely clutter
  // (where the prediction is sharp enough to say so).
  size_t at = c.size();
  if (options_.probability_order) {
    for (size_t i = 0; i < c.size(); ++i) {
      if (c[i].informative && c[i].probability < 0.5) {
        at = i;
        break;
      }
    }
  }
  f->evidenced_null = false;
  if (c.empty() && locus.empty() && options_.free_evidenced_nulls > 0) {
    // Whether the gate would hold less than one clutter point on average (Score's flag, for
    // any measurement of the data's kind: they share one noise level in practice).
    for (size_t m = 0; m < set_.points.size(); ++m) {
      if (duplicate_[m]) continue;
      const std::optional<Candidate> s =
          Score(set_.points[m].is_3d ? p3 : p2, static_cast<int>(m), false);
      f->evidenced_null = s && s->informative;
      break;
    }
  }
  c.insert(c.begin() + static_cast<long>(at), Candidate{-1, 0, 0, true});
  c.insert(c.end() - (at == c.size() - 1 ? 1 : 0), locus.begin(), locus.end());
  std::vector<Candidate> all = c;
  std::sort(all.begin(), all.end(),
            [](const Candidate& a, const Candidate& b) { return a.delta < b.delta; });
  for (const Candidate& x : all) {
    if (x.measurement >= 0 && f->best3.size() < 3) f->best3.push_back({x.measurement, x.delta});
  }
}

bool Interpreter::Blind(const Frame& f) const {
  const int component = ctx_->points[f.level].component;
  if (g_.components[component].rigid || f.own.empty()) return false;
  return std::all_of(f.own.begin(), f.own.end(), [&](int k) {
    const std::vector<int>& comps = constraint_components_[k];
    return std::any_of(comps.begin(), comps.end(),
                       [&](int c) { return c != component && f.null_component[c]; });
  });
}

void Interpreter::Leaf(const Frame& f, const std::vector<Frame>& path) {
  found_ = true;
  best_seed_support_ = seed_support_;
  best_matched_ = f.matched;
  best_delta_ = f.delta_sum;
  best_context_ = context_;
  best_assignment_ = assignment_;
  best_mean_ = f.state.mean;
  for (int l = 0; l < levels_; ++l) {
    if (preassigned_[l] >= 0) best_assignment_[l] = preassigned_[l];
  }
  best_trace_.assign(levels_, {});
  for (const auto& [level, best3] : trace_prefix_) best_trace_[level] = best3;
  for (const Frame& frame : path) best_trace_[frame.level] = frame.best3;
  best_predicted_ = 0;
  for (const Frame& frame : path) {
    const int m = assignment_[frame.level];
    if (m < 0) continue;
    for (const Candidate& c : frame.candidates) {
      if (c.measurement == m && c.informative) ++best_predicted_;
    }
  }
}

}  // namespace cfuse::internal
