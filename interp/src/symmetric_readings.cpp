#include "symmetric_readings.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {

namespace {

// A component with more points is not matched point by point (its bijections would take too
// long to enumerate, and a part that large is rarely repeated exactly).
constexpr size_t kMaxPoints = 32;
// Congruences kept per pair of components: a cube's corners have 24.
constexpr size_t kMaxCongruences = 48;
// Nodes of a bijection search, and partial readings visited by Find.
constexpr long kMaxBijectionNodes = 20000;
constexpr long kMaxReadingNodes = 5000;
// Of a component's size: how exactly a congruence must hold (model files give coordinates to a
// tenth of a millimetre, so a part turned by a third is congruent only to that).
constexpr double kRelativeTolerance = 1e-3;

using Points = std::vector<Eigen::Vector3d>;

// The point bijections of `a` onto `b` realised by a proper rigid motion, with that motion.
void Bijections(const Points& a, const Points& b, double tolerance, bool skip_identity,
                std::vector<std::pair<std::vector<int>, Rigid3d>>* out) {
  const size_t n = a.size();
  // A point can only go to one with the same sorted distances to the others.
  auto profile = [](const Points& p, size_t i) {
    std::vector<double> d;
    for (size_t k = 0; k < p.size(); ++k) {
      if (k != i) d.push_back((p[i] - p[k]).norm());
    }
    std::sort(d.begin(), d.end());
    return d;
  };
  std::vector<std::vector<double>> pa(n), pb(n);
  for (size_t i = 0; i < n; ++i) {
    pa[i] = profile(a, i);
    pb[i] = profile(b, i);
  }
  std::vector<std::vector<int>> candidates(n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) {
      bool same = true;
      for (size_t k = 0; k + 1 < n && same; ++k) same = std::abs(pa[i][k] - pb[j][k]) <= tolerance;
      if (same) candidates[i].push_back(static_cast<int>(j));
    }
    if (candidates[i].empty()) return;
  }
  std::vector<int> map(n, -1);
  std::vector<char> used(n, 0);
  long nodes = 0;
  Eigen::Matrix3Xd from(3, n), to(3, n);
  for (size_t i = 0; i < n; ++i) from.col(i) = a[i];
  auto search = [&](auto& self, size_t i) -> void {
    if (out->size() >= kMaxCongruences || ++nodes > kMaxBijectionNodes) return;
    if (i == n) {
      bool identity = true;
      for (size_t k = 0; k < n; ++k) {
        to.col(k) = b[map[k]];
        identity = identity && map[k] == static_cast<int>(k);
      }
      if (skip_identity && identity) return;
      const Eigen::Matrix4d T = Eigen::umeyama(from, to, false);
      const Rigid3d motion(Eigen::Matrix3d(T.topLeftCorner<3, 3>()),
                           Eigen::Vector3d(T.topRightCorner<3, 1>()));
      for (size_t k = 0; k < n; ++k) {
        if ((motion * a[k] - b[map[k]]).norm() > tolerance) return;
      }
      out->push_back({map, motion});
      return;
    }
    for (int j : candidates[i]) {
      if (used[j]) continue;
      bool fits = true;
      for (size_t k = 0; k < i && fits; ++k) {
        fits = std::abs((a[i] - a[k]).norm() - (b[j] - b[map[k]]).norm()) <= tolerance;
      }
      if (!fits) continue;
      map[i] = j;
      used[j] = 1;
      self(self, i + 1);
      used[j] = 0;
    }
  };
  search(search, 0);
}

double Diameter(const Points& p) {
  double d = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    for (size_t k = i + 1; k < p.size(); ++k) d = std::max(d, (p[i] - p[k]).norm());
  }
  return d;
}

}  // namespace

SymmetricReadings::SymmetricReadings(const ConstraintGraph& graph, double tolerance)
    : graph_(&graph) {
  const ConstraintGraph& g = graph;
  const size_t nc = g.components.size();
  options_.resize(nc);
  std::vector<Points> points(nc);
  for (size_t c = 0; c < nc; ++c) {
    for (const FeaturePoint& p : g.components[c].points) points[c].push_back(p.position);
  }
  for (size_t c = 0; c < nc; ++c) {
    const Component& comp = g.components[c];
    std::vector<int> identity(points[c].size());
    for (size_t i = 0; i < identity.size(); ++i) identity[i] = static_cast<int>(i);
    options_[c].push_back({static_cast<int>(c), identity, Rigid3d()});
    // A part of fewer than two points has no shape to read otherwise.
    if (!comp.rigid || points[c].size() < 2 || points[c].size() > kMaxPoints) continue;
    const double within = std::max(tolerance, kRelativeTolerance * Diameter(points[c]));
    for (size_t d = 0; d < nc; ++d) {
      if (!g.components[d].rigid || points[d].size() != points[c].size()) continue;
      std::vector<std::pair<std::vector<int>, Rigid3d>> found;
      Bijections(points[c], points[d], within, c == d, &found);
      for (auto& [map, motion] : found) {
        options_[c].push_back({static_cast<int>(d), std::move(map), motion});
        any_ = true;
      }
    }
  }
  // Rigid components breadth first over the constraints, so that each is placed next to one
  // placed before and the constraints between them prune a reading early.
  std::vector<int> component_of_block(g.blocks.size(), -1);
  for (size_t c = 0; c < nc; ++c) component_of_block[g.components[c].block] = static_cast<int>(c);
  std::vector<std::vector<int>> neighbours(nc);
  std::vector<std::vector<int>> rigid_of(g.constraints.size());
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    for (int b : g.constraints[k].blocks) {
      const int c = component_of_block[b];
      if (c >= 0 && g.components[c].rigid) rigid_of[k].push_back(c);
    }
    for (int a : rigid_of[k]) {
      for (int b : rigid_of[k]) {
        if (a != b) neighbours[a].push_back(b);
      }
    }
  }
  std::vector<char> seen(nc, 0);
  for (size_t start = 0; start < nc; ++start) {
    if (seen[start] || !g.components[start].rigid) continue;
    std::deque<int> queue = {static_cast<int>(start)};
    seen[start] = 1;
    while (!queue.empty()) {
      const int c = queue.front();
      queue.pop_front();
      order_.push_back(c);
      for (int n : neighbours[c]) {
        if (!seen[n]) {
          seen[n] = 1;
          queue.push_back(n);
        }
      }
    }
  }
  std::vector<int> position(nc, -1);
  for (size_t i = 0; i < order_.size(); ++i) position[order_[i]] = static_cast<int>(i);
  joints_at_.resize(order_.size());
  for (size_t j = 0; j < g.joints.size(); ++j) {
    const int last = std::max(position[g.joints[j].parent], position[g.joints[j].child]);
    if (position[g.joints[j].parent] >= 0 && position[g.joints[j].child] >= 0) {
      joints_at_[last].push_back(static_cast<int>(j));
    }
  }
  complete_at_.resize(order_.size());
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    int last = -1;
    for (int c : rigid_of[k]) last = std::max(last, position[c]);
    if (last >= 0) complete_at_[last].push_back(static_cast<int>(k));
  }
}

std::vector<Reading> SymmetricReadings::Find(const Values& configuration, double tolerance,
                                             int max_readings) const {
  std::vector<Reading> out;
  if (!any_ || max_readings <= 0) return out;
  const ConstraintGraph& g = *graph_;
  const size_t nc = g.components.size();
  Values work = configuration;
  std::vector<int> chosen(nc, 0);  // per component, its option
  std::vector<char> taken(nc, 0);  // per component, whether some component reads it
  long nodes = 0;
  Eigen::VectorXd r;
  // The largest violation of constraint k at `work`, an inequality's slack matched.
  auto violation = [&](int k) {
    const Constraint& c = g.constraints[k];
    double* slack = c.slack_block >= 0 && c.residual->dimension() == 1
                        ? &work.slacks[g.blocks[c.slack_block].index]
                        : nullptr;
    const double kept = slack ? *slack : 0;
    if (slack) *slack = 0;
    EvaluateResidual(*c.residual, g.blocks, c.blocks, work, &r, nullptr);
    if (slack) *slack = kept;
    if (!r.allFinite()) return std::numeric_limits<double>::infinity();
    return slack ? std::max(0.0, -r[0]) : r.lpNorm<Eigen::Infinity>();
  };
  auto search = [&](auto& self, size_t position, double worst) -> void {
    if (++nodes > kMaxReadingNodes) return;
    if (position == order_.size()) {
      const bool identity =
          std::all_of(order_.begin(), order_.end(), [&](int c) { return chosen[c] == 0; });
      if (identity) return;
      Reading reading;
      reading.source_component.resize(nc);
      reading.source_point.resize(nc);
      for (size_t c = 0; c < nc; ++c) {
        const Congruence& o = options_[c][chosen[c]];
        reading.source_component[c] = o.target;
        reading.source_point[c] = o.point_map;
      }
      reading.mean = work;
      MatchSlacks(g, &reading.mean);
      reading.violation = worst;
      out.push_back(std::move(reading));
      return;
    }
    // A joint's residual also vanishes with its axis reversed, or turned half a turn about
    // it (revolute_joint.h): a reading that turns a part over onto its own points (a flat link
    // about its spine) gets there, and is no configuration of the model.
    auto proper = [&](int j) {
      const Joint& joint = g.joints[j];
      const Eigen::Quaterniond parent =
          work.poses[g.blocks[g.components[joint.parent].block].index].rotation *
          joint.parent_from_joint.rotation;
      const Eigen::Quaterniond child =
          work.poses[g.blocks[g.components[joint.child].block].index].rotation *
          joint.child_from_joint.rotation;
      const Eigen::Quaterniond relative = parent.conjugate() * child;
      return ModelOf(joint.type).NearConfiguration(joint.axis, relative);
    };
    const int c = order_[position];
    const int index = g.blocks[g.components[c].block].index;
    for (size_t o = 0; o < options_[c].size(); ++o) {
      const Congruence& option = options_[c][o];
      if (taken[option.target]) continue;
      const int target_index = g.blocks[g.components[option.target].block].index;
      work.poses[index] = configuration.poses[target_index] * option.target_from_source;
      if (!std::all_of(joints_at_[position].begin(), joints_at_[position].end(), proper)) {
        continue;
      }
      double here = worst;
      for (int k : complete_at_[position]) {
        here = std::max(here, violation(k));
        if (here > tolerance) break;
      }
      if (here > tolerance) continue;
      taken[option.target] = 1;
      chosen[c] = static_cast<int>(o);
      self(self, position + 1, here);
      taken[option.target] = 0;
      chosen[c] = 0;
    }
    work.poses[index] = configuration.poses[index];
  };
  search(search, 0, 0.0);
  std::stable_sort(out.begin(), out.end(),
                   [](const Reading& a, const Reading& b) { return a.violation < b.violation; });
  if (out.size() > static_cast<size_t>(max_readings)) out.resize(max_readings);
  return out;
}

}  // namespace cfuse
