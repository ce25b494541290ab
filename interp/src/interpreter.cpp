// The interpretation's search state: measurements indexed once, fusion plans and their contexts,
// and the search over seeds (Run, Explore).
#include "interpreter.h"

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

namespace cfuse::internal {

Eigen::Vector3d NominalWorld(const ConstraintGraph& g, ModelPointRef p) {
  return ModelPoint(g, g.nominal, p.component, p.feature);
}

Factor MeasurementFactor(const ConstraintGraph& g, const MeasurementSet& set, ModelPointRef p,
                         int m, bool image) {
  const Component& comp = g.components[p.component];
  const Eigen::Vector3d position =
      comp.rigid ? comp.points[p.feature].position : Eigen::Vector3d::Zero();
  std::shared_ptr<const ResidualFunction> f;
  Eigen::MatrixXd noise;
  if (!image) {
    const Eigen::Vector3d z = m >= 0 ? set.points[m].xyz : Eigen::Vector3d::Zero();
    f = comp.rigid ? std::make_shared<Point3Residual>(position, z)
                   : std::make_shared<Point3Residual>(z);
    if (m >= 0) noise = set.points[m].cov3;
  } else {
    const Eigen::Vector2d z = m >= 0 ? set.points[m].uv : Eigen::Vector2d::Zero();
    f = comp.rigid ? std::make_shared<ImagePointResidual>(*set.camera, position, z)
                   : std::make_shared<ImagePointResidual>(*set.camera, z);
    if (m >= 0) noise = set.points[m].cov2;
  }
  return {f,
          {comp.block},
          noise,
          fmt::format("measurement {} of {}", m, ModelPointName(g, p.component, p.feature))};
}

double LargestVariance(const Eigen::MatrixXd& cov) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(cov, Eigen::EigenvaluesOnly)
      .eigenvalues()
      .maxCoeff();
}

double TypicalNoise(const MeasurementSet& set) {
  std::vector<double> sigmas;
  for (const MeasuredPoint& m : set.points) {
    if (m.is_3d) sigmas.push_back(std::sqrt(std::max(0.0, LargestVariance(m.cov3))));
  }
  if (sigmas.empty()) return 0;
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  return sigmas[sigmas.size() / 2];
}

Interpreter::Interpreter(const ConstraintGraph& g, const MeasurementSet& set,
                         const InterpretOptions& options, std::vector<bool> use)
    : g_(g),
      set_(set),
      options_(options),
      use_(std::move(use)),
      symmetries_(g, 3 * TypicalNoise(set)) {
  extent_ = ModelExtent(g);
  Eigen::AlignedBox3d box3;
  Eigen::AlignedBox2d box2;
  // A measurement repeated exactly (same point, same covariance) is one observation: only its
  // first copy takes part, so copies do not double the branching of every level.
  duplicate_.assign(set.points.size(), false);
  std::map<std::vector<double>, int> seen;
  for (size_t i = 0; i < set.points.size(); ++i) {
    const MeasuredPoint& m = set.points[i];
    std::vector<double> key = {m.is_3d ? 1.0 : 0.0};
    if (m.is_3d) {
      key.insert(key.end(), m.xyz.data(), m.xyz.data() + 3);
      key.insert(key.end(), m.cov3.data(), m.cov3.data() + 9);
    } else {
      key.insert(key.end(), m.uv.data(), m.uv.data() + 2);
      key.insert(key.end(), m.cov2.data(), m.cov2.data() + 4);
    }
    if (!seen.emplace(std::move(key), static_cast<int>(i)).second) {
      duplicate_[i] = true;
      continue;
    }
    if (m.is_3d) {
      box3.extend(m.xyz);
      index3_.push_back(static_cast<int>(i));
    } else {
      box2.extend(m.uv);
      index2_.push_back(static_cast<int>(i));
    }
  }
  // Lowe's clutter density q: measurements per volume of their bounding box (3D), per image
  // area (2D; the points' bounding box when the camera's size is unknown).
  if (!index3_.empty()) {
    clutter3_ = index3_.size() / box3.sizes().cwiseMax(0.1 * extent_).prod();
  }
  if (!index2_.empty()) {
    double area = box2.sizes().cwiseMax(1.0).prod();
    if (set.camera && set.camera->width > 0 && set.camera->height > 0) {
      area = static_cast<double>(set.camera->width) * set.camera->height;
    }
    clutter2_ = index2_.size() / area;
  }
  gate3_ = Gate(3);
  gate2_ = Gate(2);
  for (const Constraint& c : g.constraints) {
    constraint_components_.push_back(ConstraintComponents(g, c));
  }
  image_ = index3_.empty() && !index2_.empty();
  for (const Block& b : g.blocks) block_kinds_.push_back(b.kind);
  contexts_.push_back(MakeContext(Plan(nullptr)));
  levels_ = static_cast<int>(contexts_[0].plan.levels.size());
}

void Interpreter::Run() {
  Explore();
  complete_ = best_matched_ >= 0;
  if (best_matched_ < 0 && partial_.matched > 0) {
    // The budget ended the search before a complete interpretation: the branch that matched
    // most, its remaining levels taken as unmatched.
    best_matched_ = partial_.matched;
    best_context_ = partial_.context;
    best_seed_support_ = partial_.support;
    best_assignment_ = partial_.assignment;
    best_mean_ = partial_.mean;
    best_predicted_ = -1;
    best_trace_.assign(levels_, {});
  }
}

void Interpreter::Explore() {
  const bool image = image_;
  if (image && (!set_.camera || set_.camera->model != Camera::Model::kPinhole)) {
    Search(nullptr);  // no P3P for this camera: the unseeded search
    return;
  }
  std::vector<Seed>& seeds = seeds_;
  std::vector<bool>& searched = searched_;
  auto by_support = [](const Seed& a, const Seed& b) {
    return a.support > b.support || (a.support == b.support && a.residual < b.residual);
  };
  auto search = [&](size_t i) {
    searched[i] = true;
    searched_beyond_.resize(seeds.size(), -1);
    searched_beyond_[i] = best_matched_;
    ++stats_.seeds_tried;
    found_ = false;
    seed_support_ = seeds[i].support;
    Search(&seeds[i]);
    return stats_.status != SearchStats::Status::kBudget;
  };
  const int strong = std::max(4, levels_ / 6);
  for (const std::vector<ModelPointRef>& s : SeedSets(image)) {
    const size_t first = seeds.size();
    Seeds(s, &seeds);
    stats_.seeds = static_cast<int>(seeds.size());  // also when the budget ends the search
    searched.resize(seeds.size(), false);
    std::stable_sort(seeds.begin() + static_cast<long>(first), seeds.end(), by_support);
    // A clear winner: well supported, and by two points more than the set's next seed.
    if (seeds.size() > first && seeds[first].support >= strong &&
        (seeds.size() == first + 1 || seeds[first].support >= seeds[first + 1].support + 2) &&
        (best_matched_ < 0 || seeds[first].bound + kSupportMargin >= best_matched_)) {
      if (!search(first)) return;
    }
    if (best_matched_ >= levels_ - kLazyNulls) break;
  }
  stats_.seeds = static_cast<int>(seeds.size());
  if (seeds.empty()) {
    Search(nullptr);
    return;
  }
  std::vector<size_t> order(seeds.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return by_support(seeds[a], seeds[b]); });
  for (size_t i : order) {
    if (searched[i]) continue;
    if (best_matched_ >= 0 && seeds[i].bound + kSupportMargin < best_matched_) continue;
    // A bound counts every point of the components beyond the seed's neighbours as possible:
    // for a model of single points (the lamp) that is nearly all of them, and every seed
    // passed. Once the best leaves at most kLazyNulls points unmatched (what occlusion
    // explains, where the seed sets stop opening too), the seeds left, in order of support,
    // are searched only while their support could still beat it. A wrong partial answer (the
    // ruler's 12 of 24 points) is not that complete, so every seed its bound allows still is.
    if (best_matched_ >= levels_ - kLazyNulls &&
        seeds[i].support + kSupportMargin < best_matched_) {
      break;
    }
    if (!search(i)) return;
  }
}

FusionPlan Interpreter::Plan(const PlanStart* start) const {
  const bool image = !index2_.empty();
  const auto make = [&] { return PlanFusion(g_, image, start); };
  if (!options_.plans) return make();
  CFUSE_CHECK_MSG(&options_.plans->graph() == &g_, "a plan cache of another model");
  return options_.plans->Plan(image, start, make);
}

Context Interpreter::MakeContext(FusionPlan plan) const {
  Context c;
  c.plan = std::move(plan);
  for (const PlanLevel& l : c.plan.levels) {
    c.points.push_back({l.component, l.feature});
    c.nominal.push_back(NominalWorld(g_, c.points.back()));
    // A match's δ (its NIS plus that of the constraints placing it) is gated at the
    // chi-square quantile for the measurement's rows and those constraints' rows.
    int rows = image_ ? 2 : 3;
    for (int k : l.constraints) {
      const std::vector<int>& comps = constraint_components_[k];
      if (use_[k] && std::find(comps.begin(), comps.end(), l.component) != comps.end()) {
        rows += g_.constraints[k].residual->dimension();
      }
    }
    c.level_gate.push_back(Gate(rows));
  }
  return c;
}

int Interpreter::ContextFor(const std::vector<ModelPointRef>& s) {
  PlanStart start;
  if (g_.components[s[0].component].rigid) {
    start.components = {s[0].component};
    for (ModelPointRef p : s) start.features.push_back(p.feature);
  } else {
    for (ModelPointRef p : s) start.components.push_back(p.component);
  }
  Context c = MakeContext(Plan(&start));
  // The seed set must open the plan, in order (a triangle's order is the plan's).
  if (c.plan.seed_levels != static_cast<int>(s.size())) return -1;
  contexts_.push_back(std::move(c));
  return static_cast<int>(contexts_.size()) - 1;
}

}  // namespace cfuse::internal
