#include "cfuse/interp/schedule.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <numeric>
#include <set>

#include "cfuse/constraints/dof.h"

namespace cfuse {
namespace {

// The rigid component with the most feature points (at least 3), or -1.
int LargestRigidComponent(const ConstraintGraph& g) {
  int best = -1;
  for (size_t c = 0; c < g.components.size(); ++c) {
    const Component& comp = g.components[c];
    if (!comp.rigid || comp.points.size() < 3) continue;
    if (best < 0 || comp.points.size() > g.components[best].points.size()) {
      best = static_cast<int>(c);
    }
  }
  return best;
}

// A rigid component's features with its seed set first: the 3 spanning the largest triangle,
// then (for image data) the one farthest from their plane; the rest in model order.
std::vector<int> SeedFirstFeatures(const Component& comp, bool image_data, int* seed_size) {
  const int n = static_cast<int>(comp.points.size());
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  *seed_size = 0;
  if (n < 3) return order;
  auto p = [&](int i) { return comp.points[i].position; };
  int bi = 0, bj = 1, bk = 2;
  double best = -1;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (int k = j + 1; k < n; ++k) {
        const double area = (p(j) - p(i)).cross(p(k) - p(i)).norm();
        if (area > best * (1 + 1e-12)) {
          best = area;
          bi = i, bj = j, bk = k;
        }
      }
    }
  }
  std::vector<int> seed = {bi, bj, bk};
  if (image_data && n >= 4) {
    const Eigen::Vector3d normal = (p(bj) - p(bi)).cross(p(bk) - p(bi)).normalized();
    int fourth = -1;
    double far = -1;
    for (int l = 0; l < n; ++l) {
      if (l == bi || l == bj || l == bk) continue;
      const double d = std::abs(normal.dot(p(l) - p(bi)));
      if (d > far * (1 + 1e-12)) {
        far = d;
        fourth = l;
      }
    }
    seed.push_back(fourth);
  }
  *seed_size = static_cast<int>(seed.size());
  std::vector<int> out = seed;
  for (int i : order) {
    if (std::find(seed.begin(), seed.end(), i) == seed.end()) out.push_back(i);
  }
  return out;
}

}  // namespace

std::vector<std::array<int, 3>> RigidTriangles(const ConstraintGraph& g,
                                               const std::vector<bool>* use) {
  const int n = static_cast<int>(g.components.size());
  std::vector<std::set<int>> rigid_with(n);
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    const Constraint& c = g.constraints[k];
    if (use && !(*use)[k]) continue;
    const std::vector<int> comps = ConstraintComponents(g, c);
    const bool distance = c.kind == ConstraintKind::kDistanceEquality && comps.size() == 2;
    if (!distance && c.kind != ConstraintKind::kRigid) continue;
    for (int a : comps) {
      for (int b : comps) {
        if (a != b && !g.components[a].rigid && !g.components[b].rigid) rigid_with[a].insert(b);
      }
    }
  }
  // Pairs held at a fixed distance by other constraints together (perpendicular, coplanar,
  // angles, ...): the distance's gradient has no part along the directions the constraints
  // leave free (dof.h), to first order at the nominal geometry.
  bool other_kinds = false;
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    const Constraint& c = g.constraints[k];
    if ((use && !(*use)[k]) || c.slack_block >= 0 || c.kind == ConstraintKind::kRigid) continue;
    if (c.kind == ConstraintKind::kDistanceEquality) continue;
    const std::vector<int> comps = ConstraintComponents(g, c);
    other_kinds = other_kinds || std::any_of(comps.begin(), comps.end(),
                                             [&](int a) { return !g.components[a].rigid; });
  }
  if (other_kinds) {
    const Eigen::MatrixXd free = FreeDirections(g, g.nominal, use);
    if (free.cols() < free.rows()) {  // beyond kMaxDofStateDim nothing is shown rigid
      for (int a = 0; a < n; ++a) {
        if (g.components[a].rigid) continue;
        const Block& ba = g.blocks[g.components[a].block];
        for (int b = a + 1; b < n; ++b) {
          if (g.components[b].rigid || rigid_with[a].count(b)) continue;
          const Block& bb = g.blocks[g.components[b].block];
          const Eigen::Vector3d d = g.nominal.points[ba.index] - g.nominal.points[bb.index];
          if (d.norm() <= 0) continue;
          const Eigen::Vector3d u = d.normalized();
          // d|pa - pb| along each free direction.
          const Eigen::VectorXd change = free.middleRows<3>(ba.tangent_offset).transpose() * u -
                                         free.middleRows<3>(bb.tangent_offset).transpose() * u;
          if (change.norm() < 1e-7) {
            rigid_with[a].insert(b);
            rigid_with[b].insert(a);
          }
        }
      }
    }
  }
  auto side = [&](int a, int b) {
    return (g.nominal.points[g.blocks[g.components[a].block].index] -
            g.nominal.points[g.blocks[g.components[b].block].index])
        .norm();
  };
  std::vector<std::pair<double, std::array<int, 3>>> all;  // (-smallest side, triangle)
  for (int a = 0; a < n && all.size() < kMaxRigidTriangles; ++a) {
    for (int b : rigid_with[a]) {
      if (b <= a) continue;
      for (int c : rigid_with[b]) {
        if (c <= b || !rigid_with[a].count(c)) continue;
        all.push_back({-std::min({side(a, b), side(b, c), side(a, c)}), {a, b, c}});
      }
    }
  }
  std::sort(all.begin(), all.end());
  std::vector<std::array<int, 3>> out;
  for (const auto& [neg_side, t] : all) out.push_back(t);
  return out;
}

std::vector<int> ConstraintComponents(const ConstraintGraph& graph, const Constraint& c) {
  std::vector<int> out;
  for (int b : c.blocks) {
    for (size_t k = 0; k < graph.components.size(); ++k) {
      if (graph.components[k].block == b &&
          std::find(out.begin(), out.end(), static_cast<int>(k)) == out.end()) {
        out.push_back(static_cast<int>(k));
      }
    }
  }
  return out;
}

std::string ModelPointName(const ConstraintGraph& graph, int component, int feature) {
  const Component& c = graph.components[component];
  return feature < 0 ? c.name : c.name + "." + c.points[feature].name;
}

namespace {

// Hel-Or & Werman's fusion order (section 6), built one step at a time: which components are
// matched and which constraints fused so far, and the plan's levels in the order taken.
class FusionPlanner {
 public:
  FusionPlanner(const ConstraintGraph& g, bool image_data, const PlanStart* given)
      : g_(g),
        image_data_(image_data),
        given_(given),
        num_components_(static_cast<int>(g.components.size())),
        num_constraints_(static_cast<int>(g.constraints.size())),
        components_of_(num_constraints_),
        matched_(num_components_, false),
        fused_(num_constraints_, false) {
    std::vector<int> component_of_block(g.blocks.size(), -1);
    for (int c = 0; c < num_components_; ++c) component_of_block[g.components[c].block] = c;
    for (int k = 0; k < num_constraints_; ++k) {
      for (int b : g.constraints[k].blocks) {
        const int c = component_of_block[b];
        std::vector<int>& v = components_of_[k];
        if (c >= 0 && std::find(v.begin(), v.end(), c) == v.end()) v.push_back(c);
      }
    }
    // The start: a rigid component's seed features, or a rigid triangle of points.
    if (given) {
      start_ = given->components;
      if (start_.size() == 1 && g.components[start_[0]].rigid) rigid_start_ = start_[0];
    } else {
      rigid_start_ = LargestRigidComponent(g);
      if (rigid_start_ >= 0) {
        start_ = {rigid_start_};
      } else if (const auto triangles = RigidTriangles(g); !triangles.empty()) {
        start_.assign(triangles[0].begin(), triangles[0].end());
      }
    }
  }

  FusionPlan Plan() {
    while (Remaining(fused_) && Remaining(matched_)) {
      FuseReady();
      // (b) Components a fused constraint touches, in model order; before each, (a) again, so
      // that a constraint is fused as soon as its components are matched.
      MatchReached();
      if (!Remaining(fused_) || !Remaining(matched_)) break;
      int pick = PickHeld();
      const std::vector<int> with_pick = FusedWith(pick);
      if (pick < 0) {
        pick = PickOnStart();
        if (pick < 0) {
          // No constraint on the start set: match it first, then go on.
          for (int c : start_) {
            if (!matched_[c]) Match(c);
          }
          continue;
        }
      }
      Fuse(pick);
      for (int k : with_pick) Fuse(k);
    }
    // The components the last fused constraints reached, then those no constraint touches (the
    // start one first), then the constraints left.
    MatchReached();
    if (!start_.empty() && !matched_[start_[0]] && rigid_start_ >= 0) Match(start_[0]);
    for (int c = 0; c < num_components_; ++c) {
      if (matched_[c]) continue;
      FuseReady();
      Match(c);
    }
    for (int k = 0; k < num_constraints_; ++k) {
      if (!fused_[k]) Fuse(k);
    }
    plan_.trailing = std::move(pending_);

    // A point model's seed: its first three levels, when they are the rigid triangle.
    if (rigid_start_ < 0 && start_.size() == 3 && plan_.levels.size() >= 3) {
      std::vector<int> first = {plan_.levels[0].component, plan_.levels[1].component,
                                plan_.levels[2].component};
      std::vector<int> s = start_;
      std::sort(first.begin(), first.end());
      std::sort(s.begin(), s.end());
      if (first == s) plan_.seed_levels = 3;
    }
    return std::move(plan_);
  }

 private:
  static bool Remaining(const std::vector<bool>& done) {
    return std::count(done.begin(), done.end(), false) > 0;
  }
  bool InStart(int c) const { return std::find(start_.begin(), start_.end(), c) != start_.end(); }

  void Fuse(int k) {
    fused_[k] = true;
    pending_.push_back(k);
    for (int c : components_of_[k]) components_of_fused_.push_back(c);
  }

  // The component's levels, with the constraints fused since the last level on the first.
  void Match(int c) {
    matched_[c] = true;
    const Component& comp = g_.components[c];
    int seed_size = 0;
    std::vector<int> features =
        comp.rigid ? SeedFirstFeatures(comp, image_data_, &seed_size) : std::vector<int>{-1};
    if (given_ && c == rigid_start_ && !given_->features.empty()) {
      // The given seed features first, then the rest in model order.
      features = given_->features;
      seed_size = static_cast<int>(features.size());
      for (int f = 0; f < static_cast<int>(comp.points.size()); ++f) {
        if (std::find(given_->features.begin(), given_->features.end(), f) ==
            given_->features.end()) {
          features.push_back(f);
        }
      }
    }
    if (plan_.levels.empty()) {
      plan_.seed_levels = comp.rigid ? seed_size : 0;
      plan_.seed_is_rigid_component = comp.rigid && seed_size > 0;
    }
    for (int f : features) {
      PlanLevel level;
      level.constraints = std::move(pending_);
      pending_.clear();
      level.component = c;
      level.feature = f;
      plan_.levels.push_back(std::move(level));
    }
  }

  // (a) Constraints on matched components only.
  void FuseReady() {
    for (int k = 0; k < num_constraints_; ++k) {
      if (fused_[k]) continue;
      const std::vector<int>& comps = components_of_[k];
      if (std::all_of(comps.begin(), comps.end(), [&](int c) { return matched_[c]; })) Fuse(k);
    }
  }

  // Each unmatched component a fused constraint touches, in model order, after (a).
  void MatchReached() {
    for (int c = 0; c < num_components_; ++c) {
      if (!matched_[c] && std::find(components_of_fused_.begin(), components_of_fused_.end(), c) !=
                              components_of_fused_.end()) {
        FuseReady();
        Match(c);
      }
    }
  }

  // Rows of the unfused constraints between unmatched component u and matched ones.
  int RowsToMatched(int u) const {
    int rows = 0;
    for (int k = 0; k < num_constraints_; ++k) {
      if (fused_[k]) continue;
      const std::vector<int>& comps = components_of_[k];
      if (std::find(comps.begin(), comps.end(), u) == comps.end()) continue;
      if (std::all_of(comps.begin(), comps.end(), [&](int c) { return c == u || matched_[c]; })) {
        rows += g_.constraints[k].residual->dimension();
      }
    }
    return rows;
  }

  // (c) One constraint touching a matched component: unmatched components in the start
  // first, then the fewest unmatched, then (for one unmatched component) the one most held
  // to matched components (rows of the constraints between it and them), then the most
  // matched, then model order. -1 when none touches a matched component.
  int PickHeld() const {
    int pick = -1;
    std::tuple<int, int, int, int> best_key;
    for (int k = 0; k < num_constraints_; ++k) {
      if (fused_[k]) continue;
      int m = 0, u = 0, u_outside_start = 0, last_unmatched = -1;
      for (int c : components_of_[k]) {
        if (matched_[c]) {
          ++m;
        } else {
          ++u;
          u_outside_start += InStart(c) ? 0 : 1;
          last_unmatched = c;
        }
      }
      if (m == 0) continue;
      const int held = u == 1 ? RowsToMatched(last_unmatched) : 0;
      const std::tuple<int, int, int, int> key{u_outside_start, u, -held, -m};
      if (pick < 0 || key < best_key) {
        pick = k;
        best_key = key;
      }
    }
    return pick;
  }

  // (c') Beyond the paper: with a constraint that reaches one unmatched component, every
  // other constraint between that component and matched ones is fused too, so that its match
  // is predicted (and tested) by all of them rather than by one.
  std::vector<int> FusedWith(int pick) const {
    std::vector<int> with_pick;
    if (pick < 0) return with_pick;
    std::vector<int> unmatched;
    for (int c : components_of_[pick]) {
      if (!matched_[c]) unmatched.push_back(c);
    }
    if (unmatched.size() != 1) return with_pick;
    const int u = unmatched[0];
    for (int k = 0; k < num_constraints_; ++k) {
      if (fused_[k] || k == pick) continue;
      const std::vector<int>& comps = components_of_[k];
      if (std::find(comps.begin(), comps.end(), u) != comps.end() &&
          std::all_of(comps.begin(), comps.end(), [&](int c) { return c == u || matched_[c]; })) {
        with_pick.push_back(k);
      }
    }
    return with_pick;
  }

  // (d) Else: at the start, a constraint on the start set (touching the rigid start
  // component, or within the triangle); later, the first one left in model order. -1 when
  // no constraint is on the start set.
  int PickOnStart() const {
    const bool at_start = std::none_of(matched_.begin(), matched_.end(), [](bool b) { return b; });
    for (int k = 0; k < num_constraints_; ++k) {
      if (fused_[k]) continue;
      const std::vector<int>& comps = components_of_[k];
      const auto in_start = [&](int c) { return InStart(c); };
      const bool on_start =
          rigid_start_ >= 0
              ? std::any_of(comps.begin(), comps.end(), in_start)
              : comps.size() >= 2 && std::all_of(comps.begin(), comps.end(), in_start);
      if (!at_start || start_.empty() || on_start) return k;
    }
    return -1;
  }

  const ConstraintGraph& g_;
  const bool image_data_;
  const PlanStart* given_;
  const int num_components_, num_constraints_;
  std::vector<std::vector<int>> components_of_;  // per constraint, the components it touches
  std::vector<int> start_;
  int rigid_start_ = -1;
  FusionPlan plan_;
  std::vector<bool> matched_, fused_;
  std::vector<int> pending_;              // fused since the last level
  std::vector<int> components_of_fused_;  // components touched by fused constraints
};

}  // namespace

FusionPlan PlanFusion(const ConstraintGraph& g, bool image_data, const PlanStart* given) {
  CheckGraph(g);
  return FusionPlanner(g, image_data, given).Plan();
}

std::string FormatPlan(const ConstraintGraph& g, const FusionPlan& plan) {
  std::string out = fmt::format("fusion plan for '{}': {} levels, {} constraints\n", g.name,
                                plan.levels.size(), g.constraints.size());
  if (plan.seed_levels > 0) {
    std::string seed;
    for (int i = 0; i < plan.seed_levels; ++i) {
      seed += (i ? ", " : "") + ModelPointName(g, plan.levels[i].component, plan.levels[i].feature);
    }
    out += fmt::format("seed: {} (a pose in closed form from their matches)\n", seed);
  } else {
    // Without a seed the interpretation tree starts from the prior alone: each level gated about
    // a pose nothing has fixed yet, which in clutter matches slowly or wrongly.
    out +=
        "warning: no seed: no three points are held rigid (by a rigid component or by "
        "distances between them), so interpretation starts from the prior alone; make the "
        "part a rigid component, or add the distances that hold it rigid\n";
  }
  auto names = [&](const std::vector<int>& constraints) {
    std::string s;
    for (int k : constraints) s += (s.empty() ? "" : ", ") + g.constraints[k].name;
    return s.empty() ? std::string("-") : s;
  };
  const int width = static_cast<int>(std::to_string(plan.levels.size()).size());
  for (size_t i = 0; i < plan.levels.size(); ++i) {
    const PlanLevel& l = plan.levels[i];
    out += fmt::format("level {:>{}}: fuse {}; match {}\n", i + 1, width, names(l.constraints),
                       ModelPointName(g, l.component, l.feature));
  }
  out += fmt::format("then: fuse {}\n", names(plan.trailing));
  return out;
}

}  // namespace cfuse
