#include "cfuse/interp/simulate.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/interp/schedule.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/batch_solver.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {
namespace {

Eigen::Quaterniond UniformRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

// Every model point: (component, feature or -1) and its label.
struct ModelPointRef {
  int component, feature;
  std::string label;
};
std::vector<ModelPointRef> ModelPoints(const ConstraintGraph& g) {
  std::vector<ModelPointRef> out;
  for (size_t c = 0; c < g.components.size(); ++c) {
    const Component& comp = g.components[c];
    if (!comp.rigid) out.push_back({static_cast<int>(c), -1, comp.name});
    for (size_t f = 0; f < comp.points.size(); ++f) {
      out.push_back(
          {static_cast<int>(c), static_cast<int>(f), comp.name + "." + comp.points[f].name});
    }
  }
  return out;
}

// Joint variables drawn inside their limits, the components placed by forward kinematics, and
// every slack set from its constraint.
Values JointSample(const ConstraintGraph& g, std::mt19937& rng, double extent) {
  std::vector<JointValue> values;
  for (const Joint& j : g.joints) {
    if (!HasJointVariable(j.type) || j.mimic) continue;
    double lo = -M_PI, hi = M_PI;
    if (j.limits && j.limit_constraint >= 0) {
      const double margin = 0.1 * (j.limits->second - j.limits->first);
      lo = j.limits->first + margin;
      hi = j.limits->second - margin;
    } else if (ModelOf(j.type).VariableIsLength()) {
      lo = -0.1 * extent;
      hi = 0.1 * extent;
    }
    values.push_back({j.name, std::uniform_real_distribution<double>(lo, hi)(rng), {}});
  }
  Values sample = ForwardKinematics(g, CompleteJointValues(g, values));
  MatchSlacks(g, &sample);
  return sample;
}

Values Configuration(const ConstraintGraph& g, const SimulateOptions& options, std::mt19937& rng,
                     double extent) {
  std::vector<Factor> constraints;
  for (const Constraint& c : g.constraints)
    constraints.push_back({c.residual, c.blocks, {}, c.name});
  // A model whose freedom is not in joints (a Stewart platform's legs are ranges) has nothing
  // to sample: its configuration is perturbed as without the option.
  const bool has_joint_variable = std::any_of(
      g.joints.begin(), g.joints.end(), [](const Joint& j) { return HasJointVariable(j.type); });
  if (options.sample_joints && has_joint_variable) {
    // Constraints beyond the joints (a closed loop, an inequality between parts): the nearest
    // configuration meeting them, or another sample where there is none (a loop that cannot
    // close at the crank's angle drawn).
    for (int attempt = 0; attempt < 1000; ++attempt) {
      Values sample = JointSample(g, rng, extent);
      if (CloseLoops(g, {}, extent, true, &sample)) return sample;
    }
    throw InputError(SourceLocation(g.source),
                     "cannot simulate: no joint values drawn inside the limits (1000 tries) meet "
                     "the model's other constraints");
  }
  for (double scale = options.perturbation; scale > 1e-4; scale *= 0.5) {
    std::normal_distribution<double> n(0, 1);
    Values sample = g.nominal;
    const double sigma_position = scale * extent, sigma_rotation = 3 * scale;
    for (Eigen::Vector3d& p : sample.points)
      p += sigma_position * Eigen::Vector3d(n(rng), n(rng), n(rng));
    for (Rigid3d& pose : sample.poses) {
      pose.rotation = pose.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(
                                          sigma_rotation * n(rng),
                                          Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized()));
      pose.translation += sigma_position * Eigen::Vector3d(n(rng), n(rng), n(rng));
    }
    for (double& s : sample.slacks) s += scale * n(rng);
    PriorScale prior{sigma_position, sigma_rotation, std::max(scale, 1e-3)};
    GaussianState state = MakePrior(g.blocks, sample, prior);
    if (constraints.empty()) return sample;
    const BatchSummary summary = SolveBatch(constraints, &state, {}, &g.nominal);
    if (summary.converged && summary.max_constraint_residual <= 1e-10 * extent) return state.mean;
  }
  throw InputError(SourceLocation(g.source),
                   "cannot simulate: no configuration satisfying every constraint was found near "
                   "the nominal geometry");
}

}  // namespace

Simulation Simulate(const ConstraintGraph& graph, const SimulateOptions& options) {
  CheckGraph(graph);
  RequireEstimable(graph);
  std::mt19937 rng(options.seed);
  const double extent = ModelExtent(graph);
  Values config = Configuration(graph, options, rng, extent);
  const std::vector<ModelPointRef> refs = ModelPoints(graph);

  // The centroid of the model points, to place the object.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const ModelPointRef& r : refs) centre += ModelPoint(graph, config, r.component, r.feature);
  centre /= std::max<size_t>(1, refs.size());

  // A model with `fixed:` entries is pinned to the world frame: it is measured where it is.
  const bool pinned =
      std::any_of(graph.constraints.begin(), graph.constraints.end(),
                  [](const Constraint& c) { return c.kind == ConstraintKind::kFixed; });
  Simulation sim;
  bool placed = false;
  for (int attempt = 0; attempt < (pinned ? 1 : 200) && !placed; ++attempt) {
    Rigid3d pose(UniformRotation(rng), Eigen::Vector3d::Zero());
    std::normal_distribution<double> n(0, 1);
    if (pinned) {
      pose = Rigid3d();
    } else if (options.camera) {
      const Camera& cam = *options.camera;
      // Far enough that the model spans about 40% of the smaller image side.
      const double side = std::min(cam.width, cam.height);
      const double depth = cam.model == Camera::Model::kPinhole
                               ? 2 * extent * std::min(cam.fx, cam.fy) / (0.4 * side)
                               : 4 * extent;
      const Eigen::Vector3d target(0.1 * depth * n(rng) * 0.3, 0.1 * depth * n(rng) * 0.3, depth);
      pose.translation = target - pose.rotation * centre;
    } else {
      pose.translation = extent * Eigen::Vector3d(n(rng), n(rng), n(rng)) +
                         Eigen::Vector3d(0, 0, 4 * extent) - pose.rotation * centre;
    }
    Values moved = config;
    for (Rigid3d& p : moved.poses) p = pose * p;
    for (Eigen::Vector3d& p : moved.points) p = pose * p;
    placed = true;
    if (options.camera) {
      for (const ModelPointRef& r : refs) {
        const Eigen::Vector2d uv =
            options.camera->Project<double>(ModelPoint(graph, moved, r.component, r.feature));
        if (!uv.allFinite() || uv.x() < 0 || uv.y() < 0 || uv.x() > options.camera->width - 1 ||
            uv.y() > options.camera->height - 1) {
          placed = false;
          break;
        }
      }
    }
    if (placed) sim.truth = moved;
  }
  if (!placed) {
    throw InputError(SourceLocation(graph.source),
                     pinned ? "cannot simulate: the model is fixed in the world (`fixed:`) where "
                              "the camera, at the world origin looking along +z, does not see "
                              "every model point"
                            : "cannot simulate: no pose puts every model point inside the image");
  }

  // Measurements of the visible points, then clutter.
  std::vector<int> visible(refs.size());
  std::iota(visible.begin(), visible.end(), 0);
  std::shuffle(visible.begin(), visible.end(), rng);
  visible.resize(refs.size() - static_cast<size_t>(std::round(options.occlusion * refs.size())));
  std::sort(visible.begin(), visible.end());
  std::normal_distribution<double> n(0, 1);
  sim.measurements.camera = options.camera;
  sim.measurements.source = "simulated";
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (int i : visible) {
    const ModelPointRef& r = refs[i];
    const Eigen::Vector3d p = ModelPoint(graph, sim.truth, r.component, r.feature);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    MeasuredPoint m;
    if (options.camera) {
      m.is_3d = false;
      m.uv = options.camera->Project<double>(p) +
             options.pixel_noise * Eigen::Vector2d(n(rng), n(rng));
      m.cov2 = options.pixel_noise * options.pixel_noise * Eigen::Matrix2d::Identity();
    } else {
      m.xyz = p + options.noise * Eigen::Vector3d(n(rng), n(rng), n(rng));
      m.cov3 = options.noise * options.noise * Eigen::Matrix3d::Identity();
    }
    if (options.labels) m.label = r.label;
    sim.measurements.points.push_back(m);
    sim.matches.push_back(r.label);
  }
  const int clutter = static_cast<int>(std::round(options.clutter * visible.size()));
  std::uniform_real_distribution<double> u(0, 1);
  for (int k = 0; k < clutter; ++k) {
    MeasuredPoint m;
    if (options.camera) {
      m.is_3d = false;
      m.uv = Eigen::Vector2d(u(rng) * (options.camera->width - 1),
                             u(rng) * (options.camera->height - 1));
      m.cov2 = options.pixel_noise * options.pixel_noise * Eigen::Matrix2d::Identity();
    } else {
      m.xyz = lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
      m.cov3 = options.noise * options.noise * Eigen::Matrix3d::Identity();
    }
    sim.measurements.points.push_back(m);
    sim.matches.push_back("");
  }
  if (!options.labels) {
    std::vector<int> order(sim.measurements.points.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    MeasurementSet shuffled = sim.measurements;
    std::vector<std::string> matches(order.size());
    for (size_t i = 0; i < order.size(); ++i) {
      shuffled.points[i] = sim.measurements.points[order[i]];
      matches[i] = sim.matches[order[i]];
    }
    sim.measurements = shuffled;
    sim.matches = matches;
  }
  return sim;
}

namespace {

// The position in `values` of the model point named `name`.
std::optional<Eigen::Vector3d> NamedModelPoint(const ConstraintGraph& graph, const Values& values,
                                               const std::string& name) {
  for (size_t c = 0; c < graph.components.size(); ++c) {
    const Component& comp = graph.components[c];
    const int features = comp.rigid ? static_cast<int>(comp.points.size()) : 1;
    for (int f = 0; f < features; ++f) {
      const int feature = comp.rigid ? f : -1;
      if (ModelPointName(graph, static_cast<int>(c), feature) == name) {
        return ModelPoint(graph, values, static_cast<int>(c), feature);
      }
    }
  }
  return std::nullopt;
}

}  // namespace

bool SameModelPlace(const ConstraintGraph& graph, const Values& values, const std::string& truth,
                    const std::string& found) {
  if (truth.empty() || found.empty()) return truth.empty() && found.empty();
  if (truth == found) return true;
  const std::optional<Eigen::Vector3d> a = NamedModelPoint(graph, values, truth),
                                       b = NamedModelPoint(graph, values, found);
  return a && b && (*a - *b).norm() <= 1e-9 * ModelExtent(graph);
}

std::optional<double> ImageSeparation(const ConstraintGraph& graph, const Values& values,
                                      const Camera& camera, const std::string& truth,
                                      const std::string& found) {
  if (truth.empty() || found.empty()) return std::nullopt;
  const std::optional<Eigen::Vector3d> a = NamedModelPoint(graph, values, truth),
                                       b = NamedModelPoint(graph, values, found);
  if (!a || !b) return std::nullopt;
  return (camera.Project<double>(*a) - camera.Project<double>(*b)).norm();
}

}  // namespace cfuse
