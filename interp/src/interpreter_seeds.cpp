// Seeds of the interpretation tree: sets of model points that fix a rigid pose (triangles of
// distances, feature triples per rigid component), matched to measurement triples in closed form
// (3D: Horn; image: P3P), each ranked by its support before any tree search.
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
#include "cfuse/constraints/joint_model.h"
#include "cfuse/geometry/p3p.h"
#include "cfuse/interp/closed_form_pose.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/combined_constraint.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/image_point.h"
#include "cfuse/kernel/measurements/point3.h"
#include "interpreter.h"

namespace cfuse::internal {

std::vector<std::vector<ModelPointRef>> Interpreter::SeedSets(bool image) const {
  std::vector<std::vector<ModelPointRef>> sets;
  for (size_t c = 0; c < g_.components.size(); ++c) {
    const Component& comp = g_.components[c];
    if (!comp.rigid || comp.points.size() < (image ? 4u : 3u)) continue;
    const int n = static_cast<int>(comp.points.size());
    std::vector<std::tuple<double, int, int, int>> triples;
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        for (int k = j + 1; k < n; ++k) {
          const auto& p = comp.points;
          const double area =
              (p[j].position - p[i].position).cross(p[k].position - p[i].position).norm();
          if (area > 1e-12) triples.push_back({-area, i, j, k});
        }
    std::sort(triples.begin(), triples.end());
    std::vector<int> uses(n, 0);
    int taken = 0;
    for (const auto& [area, i, j, k] : triples) {
      if (taken == kMaxSeedSets) break;
      if (uses[i] >= 2 || uses[j] >= 2 || uses[k] >= 2) continue;
      std::vector<ModelPointRef> set = {
          {static_cast<int>(c), i}, {static_cast<int>(c), j}, {static_cast<int>(c), k}};
      if (image) {
        const auto& p = comp.points;
        const Eigen::Vector3d normal =
            (p[j].position - p[i].position).cross(p[k].position - p[i].position).normalized();
        int fourth = -1;
        double far = 1e-9 * extent_;
        for (int l = 0; l < n; ++l) {
          if (l == i || l == j || l == k) continue;
          const double d = std::abs(normal.dot(p[l].position - p[i].position));
          if (d > far) {
            far = d;
            fourth = l;
          }
        }
        if (fourth < 0) continue;  // a planar component: P3P's fourth check needs depth
        set.push_back({static_cast<int>(c), fourth});
      }
      for (int x : {i, j, k}) ++uses[x];
      sets.push_back(set);
      ++taken;
    }
  }
  if (!image) {
    for (const std::array<int, 3>& t : SeedTriangles()) {
      sets.push_back({{t[0], -1}, {t[1], -1}, {t[2], -1}});
    }
  }
  return sets;
}

std::vector<std::array<int, 3>> Interpreter::SeedTriangles() const {
  std::vector<std::array<int, 3>> out;
  std::vector<int> uses(g_.components.size(), 0);
  const auto make = [&] { return RigidTriangles(g_, &use_); };
  const std::vector<std::array<int, 3>> triangles =
      options_.plans ? options_.plans->Triangles(options_.use_constraints_between_components, make)
                     : make();
  for (const std::array<int, 3>& t : triangles) {
    if (static_cast<int>(out.size()) == kMaxSeedSets) break;
    if (uses[t[0]] >= 2 || uses[t[1]] >= 2 || uses[t[2]] >= 2) continue;
    for (int x : t) ++uses[x];
    out.push_back(t);
  }
  return out;
}

void Interpreter::Seeds(const std::vector<ModelPointRef>& s, std::vector<Seed>* seeds) {
  const int context = ContextFor(s);
  if (context < 0) return;
  // The seed set in the plan's order (a triangle may open in another order).
  std::vector<ModelPointRef> ordered;
  for (int l = 0; l < static_cast<int>(s.size()); ++l) {
    ordered.push_back(contexts_[context].points[l]);
  }
  if (image_) {
    ImageSeeds(ordered, context, seeds);
  } else {
    PointSeeds(ordered, context, seeds);
  }
}

void Interpreter::PointSeeds(const std::vector<ModelPointRef>& s, int context,
                             std::vector<Seed>* seeds) const {
  const double k = std::sqrt(Gate(1));
  std::array<Eigen::Vector3d, 3> model;
  for (int i = 0; i < 3; ++i) model[i] = NominalWorld(g_, s[i]);
  const double d01 = (model[0] - model[1]).norm(), d12 = (model[1] - model[2]).norm(),
               d02 = (model[0] - model[2]).norm();
  const int n = static_cast<int>(index3_.size());
  auto x = [&](int i) -> const Eigen::Vector3d& { return set_.points[index3_[i]].xyz; };
  if (distance_.rows() != n) {
    // Shared by every seed set: the measurements' largest variances and pairwise distances.
    sigma2_.resize(n);
    for (int i = 0; i < n; ++i) sigma2_[i] = LargestVariance(set_.points[index3_[i]].cov3);
    distance_.resize(n, n);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) distance_(i, j) = (x(i) - x(j)).norm();
  }
  auto fits = [&](int i, int j, double d, double* r2) {
    const double e = distance_(i, j) - d, var = sigma2_[i] + sigma2_[j];
    *r2 += e * e / var;
    return e * e <= k * k * var;
  };
  // Pairs for the seed's first side, then its third point against both.
  std::vector<std::vector<int>> near12(n);
  for (int j = 0; j < n; ++j) {
    for (int l = 0; l < n; ++l) {
      double r = 0;
      if (l != j && fits(j, l, d12, &r)) near12[j].push_back(l);
    }
  }
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      double r01 = 0;
      if (j == i || !fits(i, j, d01, &r01)) continue;
      for (int l : near12[j]) {
        double r = r01;
        if (l == i || !fits(j, l, d12, &r) || !fits(i, l, d02, &r)) continue;
        Rigid3d pose;
        if (!AbsoluteOrientation({model[0], model[1], model[2]}, {x(i), x(j), x(l)}, &pose)) {
          continue;
        }
        Seed seed;
        seed.context = context;
        seed.assignment = {{0, index3_[i]}, {1, index3_[j]}, {2, index3_[l]}};
        seed.world_from_nominal = pose;
        seed.residual = r;
        Support(&seed, false);
        seeds->push_back(std::move(seed));
      }
    }
  }
}

void Interpreter::ImageSeeds(const std::vector<ModelPointRef>& s, int context,
                             std::vector<Seed>* seeds) {
  const Camera& camera = *set_.camera;
  const int comp = s[0].component;
  const Rigid3d world_from_comp = g_.nominal.poses[g_.blocks[g_.components[comp].block].index];
  std::array<Eigen::Vector3d, 3> object;
  for (int i = 0; i < 3; ++i) object[i] = g_.components[comp].points[s[i].feature].position;
  const Eigen::Vector3d fourth = g_.components[comp].points[s[3].feature].position;
  const int n = static_cast<int>(index2_.size());
  const double k2 = std::sqrt(gate2_);
  if (sigma2_image_.size() != n) {
    // Computed once: the check below runs for every P3P solution.
    sigma2_image_.resize(n);
    for (int m = 0; m < n; ++m) sigma2_image_[m] = LargestVariance(set_.points[index2_[m]].cov2);
    bearings_.resize(n);
    for (int m = 0; m < n; ++m) {
      if (!PixelBearing(camera, set_.points[index2_[m]].uv, &bearings_[m])) bearings_.clear();
      if (bearings_.empty()) break;
    }
    ImageBins& bins = image_bins_;
    Eigen::AlignedBox2d box;
    for (int m = 0; m < n; ++m) box.extend(set_.points[index2_[m]].uv);
    bins.cell = std::max(k2 * std::sqrt(sigma2_image_.maxCoeff()), 1e-9);
    bins.origin = box.min();
    bins.columns = std::clamp(static_cast<int>(box.sizes().x() / bins.cell) + 1, 1, 256);
    bins.rows = std::clamp(static_cast<int>(box.sizes().y() / bins.cell) + 1, 1, 256);
    bins.cell = std::max({bins.cell, box.sizes().x() / bins.columns * (1 + 1e-12),
                          box.sizes().y() / bins.rows * (1 + 1e-12)});
    std::vector<std::vector<int>> cells(static_cast<size_t>(bins.columns) * bins.rows);
    for (int m = 0; m < n; ++m) {  // in order: each cell's entries ascending
      const Eigen::Vector2d c = (set_.points[index2_[m]].uv - bins.origin) / bins.cell;
      const int x = std::clamp(static_cast<int>(c.x()), 0, bins.columns - 1);
      const int y = std::clamp(static_cast<int>(c.y()), 0, bins.rows - 1);
      cells[static_cast<size_t>(y) * bins.columns + x].push_back(m);
    }
    bins.start = {0};
    bins.entries.clear();
    for (const std::vector<int>& cell : cells) {
      bins.entries.insert(bins.entries.end(), cell.begin(), cell.end());
      bins.start.push_back(static_cast<int>(bins.entries.size()));
    }
  }
  if (bearings_.empty()) return;  // no P3P for this camera model
  const ImageBins& bins = image_bins_;
  std::array<Rigid3d, 4> poses;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int l = 0; l < n; ++l) {
        if (i == j || j == l || i == l) continue;
        if (p3p_calls_ >= kMaxP3pCalls) return;
        ++p3p_calls_;
        const int found =
            ThreePointPoses({bearings_[i], bearings_[j], bearings_[l]}, object, &poses);
        for (int p = 0; p < found; ++p) {
          const Rigid3d& camera_from_comp = poses[p];
          const Eigen::Vector3d q = camera_from_comp * fourth;
          if (!(q.z() > 0)) continue;
          const Eigen::Vector2d uv = camera.Project<double>(q);
          // The nearest measurement (in its own deviations) inside its gate, the first of equals
          // in index2_'s order: every one inside lies in the 3 x 3 cells about uv.
          int match = -1;
          double best = 0;
          const Eigen::Vector2d c = (uv - bins.origin) / bins.cell;
          if (!(c.x() > -1 && c.y() > -1 && c.x() < bins.columns + 1 && c.y() < bins.rows + 1)) {
            continue;
          }
          const int cx = static_cast<int>(std::floor(c.x())),
                    cy = static_cast<int>(std::floor(c.y()));
          for (int y = std::max(cy - 1, 0); y <= std::min(cy + 1, bins.rows - 1); ++y) {
            for (int x = std::max(cx - 1, 0); x <= std::min(cx + 1, bins.columns - 1); ++x) {
              const size_t b = static_cast<size_t>(y) * bins.columns + x;
              for (int e = bins.start[b]; e < bins.start[b + 1]; ++e) {
                const int m = bins.entries[e];
                if (m == i || m == j || m == l) continue;
                const double d2 =
                    (set_.points[index2_[m]].uv - uv).squaredNorm() / sigma2_image_[m];
                if (d2 > k2 * k2) continue;
                const double d = std::sqrt(d2);
                if (match < 0 || d < best || (d == best && m < match)) {
                  match = m;
                  best = d;
                }
              }
            }
          }
          if (match < 0) continue;
          Seed seed;
          seed.context = context;
          seed.assignment = {
              {0, index2_[i]}, {1, index2_[j]}, {2, index2_[l]}, {3, index2_[match]}};
          seed.world_from_nominal = camera_from_comp * world_from_comp.Inverse();
          seed.residual = best * best;
          Support(&seed, true);
          seeds->push_back(std::move(seed));
        }
      }
}

const std::vector<Rigid3d>& Interpreter::JointSweep(int j) const {
  if (auto it = sweeps_.find(j); it != sweeps_.end()) return it->second;
  std::vector<Rigid3d>& out = sweeps_[j];
  const Joint& joint = g_.joints[j];
  if (!HasJointVariable(joint.type) || !g_.components[joint.parent].rigid ||
      !g_.components[joint.child].rigid) {
    return out;
  }
  const double radius = 0.05 * extent_;
  const Rigid3d world_from_joint =
      g_.nominal.poses[g_.blocks[g_.components[joint.parent].block].index] *
      joint.parent_from_joint;
  double reach = 0;
  for (const int c : {joint.parent, joint.child}) {  // either side may be the one swept
    for (const FeaturePoint& p : g_.components[c].points) {
      const Eigen::Vector3d x =
          g_.nominal.poses[g_.blocks[g_.components[c].block].index] * p.position;
      reach = std::max(reach, (world_from_joint.Inverse() * x).norm());
    }
  }
  double lower = -M_PI, upper = M_PI;
  int samples = 1;
  if (ModelOf(joint.type).VariableIsLength()) {
    if (!joint.limits) return out;
    std::tie(lower, upper) = *joint.limits;
    samples = static_cast<int>(std::ceil((upper - lower) / radius)) + 1;
  } else {
    if (joint.limits && joint.type == JointType::kRevolute) {
      std::tie(lower, upper) = *joint.limits;
    }
    samples = static_cast<int>(std::ceil((upper - lower) * reach / radius)) + 1;
  }
  if (samples > kMaxSweepSamples) return out;  // too long a sweep for a cheap estimate
  const Rigid3d undo_nominal =
      JointMotion(joint.type, joint.axis, joint.nominal_position).Inverse();
  for (int i = 0; i < samples; ++i) {
    // Inside the range, never on a bound: a slack matched to a joint at its bound is zero,
    // where it has no derivative, and its constraint linearised there pins the joint at the
    // bound for the whole branch (the folding ruler swept to its end stops).
    const double q = lower + (upper - lower) * (i + 0.5) / samples;
    out.push_back(world_from_joint * JointMotion(joint.type, joint.axis, q) * undo_nominal *
                  world_from_joint.Inverse());
  }
  return out;
}

std::vector<Rigid3d> Interpreter::TurnedStarts(const Seed& seed, const Context& ctx) const {
  std::vector<Rigid3d> out;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double noise = 0;
  for (const auto& [level, m] : seed.assignment) {
    centre += ctx.nominal[level];
    noise = std::max(noise, LargestVariance(set_.points[m].cov3));
  }
  centre /= static_cast<double>(seed.assignment.size());
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  for (const auto& [level, m] : seed.assignment) {
    const Eigen::Vector3d q = ctx.nominal[level] - centre;
    spread += q.squaredNorm() * Eigen::Matrix3d::Identity() - q * q.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(spread);
  const double turn_sigma =
      eigen.eigenvalues()[0] > 0 ? std::sqrt(noise / eigen.eigenvalues()[0]) : 1.0;
  double reach = 0;
  for (int l = 0; l < levels_; ++l) reach = std::max(reach, (ctx.nominal[l] - centre).norm());
  const double step = 0.05 * extent_ / std::max(reach, 1e-9);
  const double span = 3 * std::min(turn_sigma, 1.0);  // radians either way
  const int turns = std::min(8, static_cast<int>(std::ceil(span / step)));
  const Eigen::Vector3d axis = seed.world_from_nominal.rotation * eigen.eigenvectors().col(0);
  const Eigen::Vector3d pivot = seed.world_from_nominal * centre;
  for (int k = -turns; turns > 1 && k <= turns; ++k) {
    if (k == 0) continue;
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(span * k / turns, axis).toRotationMatrix();
    out.push_back(Rigid3d(turn, pivot - turn * pivot) * seed.world_from_nominal);
  }
  return out;
}

void Interpreter::Support(Seed* seed_out, bool image) const {
  Seed& seed = *seed_out;
  std::vector<int> exclude;
  for (const auto& [level, m] : seed.assignment) exclude.push_back(m);
  std::vector<std::pair<Eigen::Vector3d, int>> points;
  if (!image) {
    if (!grid3_) {
      for (int i : index3_) points.push_back({set_.points[i].xyz, i});
      grid3_.emplace(0.05 * extent_, 3, points);
    }
  } else if (!grid2_) {
    const Camera& c = *set_.camera;
    diagonal_ = c.width > 0 ? std::hypot(c.width, c.height) : 1000.0;
    for (int i : index2_) {
      points.push_back({Eigen::Vector3d(set_.points[i].uv.x(), set_.points[i].uv.y(), 0), i});
    }
    grid2_.emplace(0.03 * diagonal_, 2, points);
  }
  const Context& ctx = contexts_[seed.context];
  const int own = ctx.points[0].component;
  auto near = [&](const Eigen::Vector3d& x) {
    if (!image) return grid3_->AnyWithin(x, 0.05 * extent_, exclude);
    if (!(x.z() > 0)) return false;
    const Eigen::Vector2d uv = set_.camera->Project<double>(x);
    return grid2_->AnyWithin(Eigen::Vector3d(uv.x(), uv.y(), 0), 0.03 * diagonal_, exclude);
  };
  const std::vector<std::vector<int>>& levels_of = LevelsOf(seed.context);
  if (joints_of_.empty()) {
    joints_of_.resize(g_.components.size());
    for (size_t j = 0; j < g_.joints.size(); ++j) {
      joints_of_[g_.joints[j].parent].push_back(static_cast<int>(j));
      joints_of_[g_.joints[j].child].push_back(static_cast<int>(j));
    }
  }
  // From the own component placed at `start`: each component joined to it, and on along the
  // chain, where its joint's sweep brings the most points near a measurement; the points so
  // brought near (support, the own component's included); and per level of the own
  // component and of each component joined to it, whether it is near a measurement
  // somewhere along the sweep (empty: not swept). Only these can match, wherever the joint
  // is. Components farther along a chain can sit in more places than one sweep shows.
  struct Placing {
    Rigid3d start;
    std::vector<Rigid3d> placement;
    std::vector<bool> placed;
    std::vector<std::vector<bool>> reached;  // per component, per level of levels_of
    int support = 0;
  };
  auto place = [&](const Rigid3d& start) {
    Placing out;
    out.start = start;
    out.placement.assign(g_.components.size(), start);
    out.placed.assign(g_.components.size(), false);
    out.reached.resize(g_.components.size());
    out.placed[own] = true;
    std::vector<bool>& own_reached = out.reached[own];
    for (int level : levels_of[own]) {
      own_reached.push_back(near(start * ctx.nominal[level]));
      out.support += own_reached.back() ? 1 : 0;
    }
    std::vector<int> queue = {own};
    for (size_t head = 0; head < queue.size(); ++head) {
      const int c = queue[head];
      for (const int j : joints_of_[c]) {
        const Joint& joint = g_.joints[j];
        const int other = joint.parent == c ? joint.child : joint.parent;
        if (out.placed[other]) continue;
        const std::vector<Rigid3d>& sweep = JointSweep(j);
        // In an image a long sweep finds some clutter near most of its places, and a
        // placement chosen that way is worse than the nominal one (the four-bar from one
        // camera: right in 14 % of trials with whole turns swept, 36 % without).
        if (sweep.empty() || (image && sweep.size() > kMaxImageSweepSamples)) continue;
        const std::vector<int>& levels = levels_of[other];
        std::vector<bool> reached(levels.size(), false);
        int most = 0;
        Rigid3d best = out.placement[c];
        for (const Rigid3d& delta : sweep) {
          const Rigid3d moved = out.placement[c] * (joint.parent == c ? delta : delta.Inverse());
          int count = 0;
          for (size_t i = 0; i < levels.size(); ++i) {
            if (near(moved * ctx.nominal[levels[i]])) {
              ++count;
              reached[i] = true;
            }
          }
          if (count > most) {
            most = count;
            best = moved;
          }
        }
        if (c == own) out.reached[other] = std::move(reached);
        out.placement[other] = best;
        out.placed[other] = true;
        out.support += most;
        queue.push_back(other);
      }
    }
    return out;
  };
  std::vector<Placing> placings = {place(seed.world_from_nominal)};
  if (!image && !joints_of_[own].empty()) {
    for (const Rigid3d& start : TurnedStarts(seed, ctx)) placings.push_back(place(start));
  }
  int bound = 0;
  for (size_t c = 0; c < g_.components.size(); ++c) {
    if (placings[0].reached[c].empty() && static_cast<int>(c) != own) {
      bound += static_cast<int>(levels_of[c].size());  // not swept: anywhere
      continue;
    }
    for (size_t i = 0; i < placings[0].reached[c].size(); ++i) {
      bound += std::any_of(placings.begin(), placings.end(),
                           [&](const Placing& p) { return p.reached[c][i]; })
                   ? 1
                   : 0;
    }
  }
  const Placing& placing =
      *std::max_element(placings.begin(), placings.end(),
                        [](const Placing& a, const Placing& b) { return a.support < b.support; });
  seed.world_from_nominal = placing.start;
  seed.placement = placing.placement;
  // Single points and components no joint reaches: at the seed's motion of the nominal
  // geometry.
  int support = placing.support;
  for (int l = 0; l < levels_; ++l) {
    const int c = ctx.points[l].component;
    if (placing.placed[c]) continue;
    support += near(seed.world_from_nominal * ctx.nominal[l]) ? 1 : 0;
  }
  seed.support = support;
  seed.bound = bound;
}

const std::vector<std::vector<int>>& Interpreter::LevelsOf(int context) const {
  if (auto it = levels_of_.find(context); it != levels_of_.end()) return it->second;
  std::vector<std::vector<int>>& out = levels_of_[context];
  out.resize(g_.components.size());
  for (int l = 0; l < levels_; ++l) out[contexts_[context].points[l].component].push_back(l);
  return out;
}

}  // namespace cfuse::internal
