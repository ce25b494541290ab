#include "cfuse/interp/solve.h"

#include "cfuse/interp/joint_estimates.h"

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

namespace cfuse {
namespace {

// Model points (in some frame) paired with their measurements, 3D and 2D apart.
struct Correspondences {
  std::vector<Eigen::Vector3d> model3, measured3, model2;
  std::vector<Eigen::Vector2d> measured2;

  void Add(const Eigen::Vector3d& model, const MeasuredPoint& m) {
    if (m.is_3d) {
      model3.push_back(model);
      measured3.push_back(m.xyz);
    } else {
      model2.push_back(model);
      measured2.push_back(m.uv);
    }
  }
};

// Unmeasured single points start where the rigid guess puts them, which is off by however far
// the articulation moved them, and a constraint linearised there can throw the sequential
// pass far along a direction it leaves free. So each is first placed where its constraints to
// known points (measured, or placed before it) hold best, most constrained first.
void PlaceUnmeasured(const ConstraintGraph& g, const std::vector<bool>& measured, Values* x) {
  std::vector<std::vector<int>> components_of(g.constraints.size());
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    for (int b : g.constraints[k].blocks) {
      for (size_t c = 0; c < g.components.size(); ++c) {
        if (g.components[c].block == b) components_of[k].push_back(static_cast<int>(c));
      }
    }
  }
  std::vector<bool> known = measured;
  while (true) {
    int best = -1;
    std::vector<int> best_list;
    int best_rows = 0;
    for (size_t c = 0; c < g.components.size(); ++c) {
      if (known[c] || g.components[c].rigid) continue;
      std::vector<int> list;
      int rows = 0;
      for (size_t k = 0; k < g.constraints.size(); ++k) {
        const std::vector<int>& comps = components_of[k];
        if (std::find(comps.begin(), comps.end(), static_cast<int>(c)) == comps.end()) continue;
        const bool others_known = std::all_of(comps.begin(), comps.end(), [&](int n) {
          return n == static_cast<int>(c) || known[n];
        });
        if (!others_known) continue;
        list.push_back(static_cast<int>(k));
        rows += g.constraints[k].residual->dimension();
      }
      if (rows > best_rows) {
        best = static_cast<int>(c);
        best_rows = rows;
        best_list = std::move(list);
      }
    }
    // Fewer than three rows leave the point a curve or a surface: its guess stays.
    if (best < 0 || best_rows < 3) return;
    PlacePoint(g, best_list, g.components[best].block, x,
               {.max_iterations = 50, .min_damping = 1e-12, .max_damping = 1e12});
    known[best] = true;
  }
}

// measured_from_model in closed form: absolute orientation from 3D points, else from image
// points (the PnP solver for a pinhole camera; OrthographicPose, with the model points'
// centroid kept at `depth`, for an orthographic one); false when there are too few points.
bool ClosedFormPose(const Correspondences& k, const MeasurementSet& set,
                    const SolveOptions& options, double depth, Rigid3d* pose) {
  Rigid3d found;  // *pose is written only on success
  bool ok = AbsoluteOrientation(k.model3, k.measured3, &found);
  if (!ok && set.camera && set.camera->model == Camera::Model::kOrthographic) {
    ok = OrthographicPose(*set.camera, k.model2, k.measured2, depth, &found);
  } else if (!ok && set.camera && k.model2.size() >= 4 && options.pose_from_projections) {
    ok = options.pose_from_projections(*set.camera, k.model2, k.measured2, &found);
  }
  if (ok) *pose = found;
  return ok;
}

// The mean depth (z) of points.
double MeanDepth(const std::vector<Eigen::Vector3d>& points) {
  double z = 0;
  for (const Eigen::Vector3d& p : points) z += p.z();
  return points.empty() ? 0 : z / static_cast<double>(points.size());
}

Rigid3d& PoseOf(const ConstraintGraph& g, Values& v, int component) {
  return v.poses[g.blocks[g.components[component].block].index];
}

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

// rᵀ R⁻¹ r of a labelled measurement at `values` (R its noise), or infinity when r is not
// finite.
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

// A measurement's distance from the estimate in the spread its residual should have there:
// rᵀ S⁻¹ r with S = R − A P Aᵀ for a measurement the estimate includes (what is left of its
// noise once the estimate has leant on it: the same as its distance from the estimate without
// it), and S = R + A P Aᵀ for one it does not. Chi-square with the measurement's dimension for
// a good measurement either way. A measurement the estimate follows exactly (a single point
// measured once, with nothing else to check it) cannot be judged: 0.
double GateSquare(const ConstraintGraph& graph, const MeasurementSet& set,
                  const ResolvedLabel& r, const GaussianState& state, bool included) {
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
  const Eigen::MatrixXd s = included ? Eigen::MatrixXd(noise - spread) : Eigen::MatrixXd(noise + spread);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(s);
  if (!(eigen.eigenvalues().minCoeff() > 1e-6 * noise.trace())) return 0;
  return residual.dot(s.llt().solve(residual));
}

}  // namespace

void ApplyGuess(const ConstraintGraph& graph, const PoseSet& guess, Values* values) {
  // A frame on a component (a merged URDF link, as results and `fk` write them) places its
  // component, unless the component's own pose is given too.
  for (const NamedPose& p : guess.components) {
    if (graph.FindComponent(p.name) >= 0) continue;
    const auto frame = graph.FindFrame(p.name);
    if (!frame) {
      std::vector<std::string> names;
      for (const Component& comp : graph.components) {
        names.push_back(comp.name);
        for (const ComponentFrame& f : comp.frames) names.push_back(f.name);
      }
      throw InputError(p.where,
                       fmt::format("unknown component '{}'{}", p.name, DidYouMean(p.name, names)));
    }
    const int c = frame->first;  // not a structured binding: captured below (clang < 16)
    const Rigid3d& component_from_frame = frame->second;
    const bool given =
        std::any_of(guess.components.begin(), guess.components.end(),
                    [&](const NamedPose& q) { return graph.FindComponent(q.name) == c; });
    if (!given) PoseOf(graph, *values, c) = p.pose * component_from_frame.Inverse();
  }
  for (const NamedPose& p : guess.components) {
    const int c = graph.FindComponent(p.name);
    if (c < 0) continue;  // a frame, above
    if (!graph.components[c].rigid) {
      throw InputError(p.where,
                       fmt::format("'{}' is a single point: give it under 'points'", p.name));
    }
    PoseOf(graph, *values, c) = p.pose;
  }
  for (const NamedPoint& p : guess.points) {
    const int c = graph.FindComponent(p.name);
    if (c < 0 || graph.components[c].rigid) {
      throw InputError(p.where, fmt::format("unknown point '{}'{}", p.name,
                                            c >= 0 ? ": it is a rigid component" : ""));
    }
    values->points[graph.blocks[graph.components[c].block].index] = p.xyz;
  }
}

Eigen::Vector3d ModelPoint(const ConstraintGraph& graph, const Values& values, int component,
                           int feature) {
  const Component& c = graph.components[component];
  const Block& b = graph.blocks[c.block];
  if (!c.rigid) return values.points[b.index];
  return values.poses[b.index] * c.points[feature].position;
}

double ModelExtent(const ConstraintGraph& graph) {
  std::vector<Eigen::Vector3d> points;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    const Component& comp = graph.components[c];
    if (!comp.rigid) points.push_back(ModelPoint(graph, graph.nominal, static_cast<int>(c), -1));
    for (size_t f = 0; f < comp.points.size(); ++f) {
      points.push_back(ModelPoint(graph, graph.nominal, static_cast<int>(c), static_cast<int>(f)));
    }
    if (comp.rigid)
      points.push_back(graph.nominal.poses[graph.blocks[comp.block].index].translation);
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centre += p;
  centre /= std::max<size_t>(1, points.size());
  double extent = 1e-3;
  for (const Eigen::Vector3d& p : points) extent = std::max(extent, (p - centre).norm());
  return extent;
}

bool PlacePoint(const ConstraintGraph& g, const std::vector<int>& list, int block, Values* x,
                const PlaceOptions& options) {
  Eigen::Vector3d& p = x->points[g.blocks[block].index];
  auto evaluate = [&](Eigen::VectorXd* residual, Eigen::MatrixXd* jacobian) {
    std::vector<double> rows;
    std::vector<Eigen::RowVector3d> gradients;
    Eigen::VectorXd r;
    Eigen::MatrixXd H;
    for (int k : list) {
      const Constraint& c = g.constraints[k];
      EvaluateResidual(*c.residual, g.blocks, c.blocks, *x, &r, jacobian ? &H : nullptr);
      for (int i = 0; i < r.size(); ++i) rows.push_back(r(i));
      if (!jacobian) continue;
      int column = 0;
      for (int b : c.blocks) {
        if (b == block) {
          for (int i = 0; i < r.size(); ++i) gradients.push_back(H.block<1, 3>(i, column));
        }
        column += TangentDim(g.blocks[b].kind);
      }
    }
    *residual = Eigen::Map<Eigen::VectorXd>(rows.data(), static_cast<long>(rows.size()));
    if (jacobian) {
      jacobian->resize(static_cast<long>(gradients.size()), 3);
      for (size_t i = 0; i < gradients.size(); ++i) {
        jacobian->row(static_cast<long>(i)) = gradients[i];
      }
    }
  };
  Eigen::VectorXd r, next;
  Eigen::MatrixXd J;
  evaluate(&r, &J);
  if (!r.allFinite() || !J.allFinite()) return false;
  if (J.rows() != r.size()) return true;  // the point appears in none of the residuals
  double cost = r.squaredNorm(), lambda = 1e-3;
  for (int it = 0; it < options.max_iterations && cost > 0; ++it) {
    const Eigen::Matrix3d JtJ = J.transpose() * J;
    const Eigen::Vector3d step =
        -(JtJ + lambda * Eigen::Matrix3d(JtJ.diagonal().cwiseMax(1e-12).asDiagonal()))
             .ldlt()
             .solve(J.transpose() * r);
    const Eigen::Vector3d before = p;
    p += step;
    evaluate(&next, nullptr);
    if (next.allFinite() && next.squaredNorm() < cost) {
      cost = next.squaredNorm();
      lambda = std::max(lambda / 10, options.min_damping);
      evaluate(&r, &J);
      if (step.norm() <= 1e-12 * (1 + p.norm())) break;
    } else {
      p = before;
      lambda *= 10;
      if (lambda > options.max_damping) break;
    }
  }
  return true;
}

// Every label a measurement could carry, for "did you mean": component.point, bare point
// names and single-point components.
static std::vector<std::string> KnownLabels(const ConstraintGraph& graph) {
  std::vector<std::string> known;
  for (const Component& comp : graph.components) {
    if (!comp.rigid) known.push_back(comp.name);
    if (!comp.rigid) continue;
    for (const FeaturePoint& p : comp.points) {
      known.push_back(comp.name + "." + p.name);
      known.push_back(p.name);
    }
  }
  return known;
}

// Labelled 3D points in other units than the model's (millimetres read as metres) would end in
// thousands of sigmas and outliers; said at the file instead. The measure: the median, over
// pairs of labelled points on one rigid component, of their measured over their model distance.
static void RequireModelScale(const ConstraintGraph& graph, const MeasurementSet& set,
                              const std::vector<ResolvedLabel>& labels) {
  std::map<int, std::vector<const ResolvedLabel*>> by_component;
  for (const ResolvedLabel& l : labels) {
    if (l.feature >= 0 && set.points[l.measurement].is_3d) by_component[l.component].push_back(&l);
  }
  std::vector<double> ratios;
  for (const auto& [c, on] : by_component) {
    const Component& comp = graph.components[c];
    for (size_t i = 0; i + 1 < on.size() && ratios.size() < 10000; ++i) {
      for (size_t j = i + 1; j < on.size() && j < i + 8; ++j) {
        const double model = (comp.points[on[i]->feature].position -
                              comp.points[on[j]->feature].position).norm();
        const MeasuredPoint& a = set.points[on[i]->measurement];
        const MeasuredPoint& b = set.points[on[j]->measurement];
        const double noise = std::sqrt(a.cov3.trace() + b.cov3.trace());
        const double measured = (a.xyz - b.xyz).norm();
        if (measured > 10 * noise && model > 0) ratios.push_back(measured / model);
      }
    }
  }
  if (ratios.size() < 3) return;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  const double ratio = ratios[ratios.size() / 2];
  if (ratio < 20 && ratio > 1.0 / 20) return;
  const char* guess = ratio > 500 && ratio < 2000   ? ": millimetres? measurement files take metres"
                      : ratio > 50 && ratio < 200   ? ": centimetres? measurement files take metres"
                      : ratio > 20 && ratio < 50    ? ": inches? measurement files take metres"
                                                    : "";
  const double step = std::pow(10.0, std::floor(std::log10(ratio)) - 1);  // two digits shown
  throw InputError(SourceLocation(set.source),
                   fmt::format("the labelled points are about {:g} times as far apart as the "
                               "model points they name (median over {} pairs){}",
                               std::round(ratio / step) * step, ratios.size(), guess));
}

std::vector<ResolvedLabel> ResolveLabels(const ConstraintGraph& graph, const MeasurementSet& set) {
  std::vector<ResolvedLabel> labels;
  auto unknown = [&](const MeasuredPoint& m) {
    return InputError(m.where, fmt::format("unknown label '{}': no such model point{}", m.label,
                                           DidYouMean(m.label, KnownLabels(graph))));
  };
  for (size_t i = 0; i < set.points.size(); ++i) {
    const MeasuredPoint& m = set.points[i];
    if (m.label.empty()) continue;
    ResolvedLabel r;
    r.measurement = static_cast<int>(i);
    if (m.label.find('.') != std::string::npos) {
      // component.point, split at whichever dot names a model point: a URDF link's own name
      // may hold dots.
      r.component = -1;
      for (size_t dot = m.label.find('.'); dot != std::string::npos && r.component < 0;
           dot = m.label.find('.', dot + 1)) {
        const int c = graph.FindComponent(std::string_view(m.label).substr(0, dot));
        if (c < 0 || !graph.components[c].rigid) continue;
        const int f = graph.components[c].FindPoint(std::string_view(m.label).substr(dot + 1));
        if (f >= 0) {
          r.component = c;
          r.feature = f;
        }
      }
      if (r.component < 0) throw unknown(m);
    } else {
      int matches = 0;
      for (size_t c = 0; c < graph.components.size(); ++c) {
        const Component& comp = graph.components[c];
        if (!comp.rigid && comp.name == m.label) {
          r.component = static_cast<int>(c);
          r.feature = -1;
          ++matches;
        }
        const int f = comp.rigid ? comp.FindPoint(m.label) : -1;
        if (f >= 0) {
          r.component = static_cast<int>(c);
          r.feature = f;
          ++matches;
        }
      }
      if (matches == 0) throw unknown(m);
      if (matches > 1) {
        throw InputError(m.where,
                         fmt::format("label '{}' is ambiguous: write component.point", m.label));
      }
    }
    labels.push_back(r);
  }
  RequireModelScale(graph, set, labels);
  return labels;
}

Values ClosedFormStart(const ConstraintGraph& graph, const MeasurementSet& set,
                       const std::vector<ResolvedLabel>& labels, const SolveOptions& options,
                       bool each_component) {
  // 1. A global rigid guess from all labelled points against the nominal geometry.
  Correspondences global;
  std::vector<Correspondences> per_component(graph.components.size());
  for (const ResolvedLabel& r : labels) {
    const MeasuredPoint& m = set.points[r.measurement];
    const Component& comp = graph.components[r.component];
    global.Add(ModelPoint(graph, graph.nominal, r.component, r.feature), m);
    per_component[r.component].Add(
        comp.rigid ? comp.points[r.feature].position : Eigen::Vector3d::Zero(), m);
  }
  Rigid3d world_from_nominal;
  // An orthographic camera does not see depth: the model stays at its declared depth.
  if (!ClosedFormPose(global, set, options, MeanDepth(global.model2), &world_from_nominal) &&
      (global.model3.size() == 1 || global.model3.size() == 2)) {
    // One or two 3D points: a translation at least.
    world_from_nominal =
        Rigid3d(Eigen::Quaterniond::Identity(), global.measured3[0] - global.model3[0]);
  }
  Values initial = graph.nominal;
  for (Rigid3d& pose : initial.poses) pose = world_from_nominal * pose;
  for (Eigen::Vector3d& p : initial.points) p = world_from_nominal * p;

  // 2. Each component's own closed-form start where its labels allow one.
  for (size_t c = 0; each_component && c < graph.components.size(); ++c) {
    const Component& comp = graph.components[c];
    const Correspondences& k = per_component[c];
    if (!comp.rigid) {
      if (!k.measured3.empty()) {
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const Eigen::Vector3d& p : k.measured3) mean += p;
        initial.points[graph.blocks[comp.block].index] =
            mean / static_cast<double>(k.measured3.size());
      }
      continue;
    }
    Rigid3d& current = PoseOf(graph, initial, static_cast<int>(c));
    std::vector<Eigen::Vector3d> in_world;
    for (const Eigen::Vector3d& p : k.model2) in_world.push_back(current * p);
    ClosedFormPose(k, set, options, MeanDepth(in_world), &current);
  }
  return initial;
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

namespace {

// Steps 2-4 for the measurements of `labels`: solution's state, summary, contradictions and
// invalid factors. An image measurement whose point is at or behind the camera at the start is
// not fused, and reported in `invalid`.
void SolveLabelled(const ConstraintGraph& graph, const MeasurementSet& set,
                   const SolveOptions& options, const std::vector<ResolvedLabel>& labels,
                   Solution* solution, const Values* start = nullptr) {
  solution->contradictions.clear();
  solution->invalid.clear();

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
                                      : ClosedFormStart(graph, set, labels, options);

  Values unplaced;  // the start before unmeasured points are placed: the fallback below
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
    for (size_t c = 0; c < graph.components.size(); ++c) {
      if (graph.components[c].rigid) measured[c] = true;  // placed by their closed forms
    }
    if (options.use_constraints_between_components) PlaceUnmeasured(graph, measured, &initial);
  }
  MatchSlacks(graph, &initial);

  // 3. The prior, and 4. the factors.
  PriorScale scale;
  scale.position = options.prior_extent_factor * solution->extent;
  scale.rotation = options.prior_rotation_sigma;
  scale.slack = options.prior_slack_sigma;
  solution->state = MakePrior(graph.blocks, initial, scale);
  // One factor per single point measurement, and one per rigid component stacking all its
  // measurements (measurements/stacked.h), in the order of their first measurement.
  std::vector<Factor> factors;
  std::vector<int> component_factor(graph.components.size(), -1);
  std::vector<std::vector<std::shared_ptr<const ResidualFunction>>> parts;
  std::vector<std::vector<Eigen::MatrixXd>> noises;
  for (const ResolvedLabel& r : labels) {
    const MeasuredPoint& m = set.points[r.measurement];
    const Component& comp = graph.components[r.component];
    const std::shared_ptr<const ResidualFunction> f = MeasurementResidual(graph, set, r);
    if (!m.is_3d && !std::isfinite(NormalisedSquare(graph, set, r, initial))) {
      // No projection there (Camera::Project). In its component's stacked factor it would make
      // every measurement of the component invalid, and the component silently unmeasured.
      solution->invalid.push_back(fmt::format(
          "measurement {} ({}): its model point is at or behind the camera at the start",
          r.measurement, m.label));
      continue;
    }
    const Eigen::MatrixXd noise = m.is_3d ? Eigen::MatrixXd(m.cov3) : Eigen::MatrixXd(m.cov2);
    if (!comp.rigid) {
      factors.push_back(
          {f, {comp.block}, noise, fmt::format("measurement {} ({})", r.measurement, m.label)});
      parts.emplace_back();
      noises.emplace_back();
      continue;
    }
    int& k = component_factor[r.component];
    if (k < 0) {
      k = static_cast<int>(factors.size());
      factors.push_back({nullptr, {comp.block}, {}, fmt::format("measurements of {}", comp.name)});
      parts.emplace_back();
      noises.emplace_back();
    }
    parts[k].push_back(f);
    noises[k].push_back(noise);
  }
  for (size_t k = 0; k < factors.size(); ++k) {
    if (factors[k].residual) continue;
    factors[k].residual = std::make_shared<StackedResidual>(parts[k]);
    const int dim = factors[k].residual->dimension();
    factors[k].noise = Eigen::MatrixXd::Zero(dim, dim);
    int offset = 0;
    for (const Eigen::MatrixXd& n : noises[k]) {
      factors[k].noise.block(offset, offset, n.rows(), n.cols()) = n;
      offset += static_cast<int>(n.rows());
    }
  }
  for (const Constraint& c : graph.constraints) {
    if (options.use_constraints_between_components || ConstraintComponents(graph, c).size() <= 1)
      factors.push_back({c.residual, c.blocks, {}, c.name});
  }
  std::vector<Factor> ordered;
  ordered.reserve(factors.size());
  for (int i : GroupGrowthOrder(factors, static_cast<int>(graph.blocks.size()))) {
    ordered.push_back(std::move(factors[i]));
  }
  factors = std::move(ordered);
  SequenceOptions sequence = options.sequence;
  sequence.constraint_tolerance = 1e-8 * solution->extent;
  // An answer on a limit does not claim the limit known to zero variance (a Stewart platform
  // seen by one camera, a leg estimated on its range's end and truly well inside it: the top
  // plate 135 mm off, NEES 62 under the covariance that held the boundary, 54 without it).
  sequence.boundary_free_covariance = true;
  solution->summary = FuseSequence(factors, &solution->state, sequence);
  // A converged estimate that the measurements do not fit is a local minimum as surely as an
  // unconverged one is a failure: both get the other starts, and the better fit is kept.
  const auto chi2 = [&](const GaussianState& state) {
    return AnalyseFit(factors, graph.blocks, state.mean, solution->extent, false).fit;
  };
  Fit fit = chi2(solution->state);
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
    GaussianState state = MakePrior(graph.blocks, unplaced, scale);
    SequenceSummary summary = FuseSequence(factors, &state, sequence);
    const Fit other = chi2(state);
    if (better(summary, other)) {
      solution->state = std::move(state);
      solution->summary = std::move(summary);
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
    GaussianState state = MakePrior(graph.blocks, initial, scale);
    SequenceSummary summary = FuseSequence(factors, &state, from_start);
    const Fit other = chi2(state);
    if (better(summary, other)) {
      solution->state = std::move(state);
      solution->summary = std::move(summary);
      fit = other;
    }
  }
  solution->analysis = AnalyseFit(factors, graph.blocks, solution->state.mean, solution->extent);
  for (size_t i = 0; i < factors.size(); ++i) {
    if (solution->summary.fusions[i].status == FusionSummary::Status::kContradiction) {
      solution->contradictions.push_back(factors[i].name);
    }
    if (solution->summary.fusions[i].status == FusionSummary::Status::kInvalid) {
      solution->invalid.push_back(factors[i].name + ": not finite at the estimate");
    }
  }
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

// `start` turned about the centroid of the labelled points of `component` (every rigid
// component and point when -1) so that the plane those points lie nearest to has its normal
// mirrored about the line of sight (the camera at the world's origin): the other pose a
// near-planar set of points seen in one image can take, projecting to nearly the same place.
// False when there are fewer than three such points.
bool Mirrored(const ConstraintGraph& graph, const std::vector<ResolvedLabel>& labels,
              int component, Values* start) {
  std::vector<Eigen::Vector3d> points;
  for (const ResolvedLabel& r : labels) {
    if (component < 0 || r.component == component) {
      points.push_back(ModelPoint(graph, *start, r.component, r.feature));
    }
  }
  if (points.size() < 3) return false;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::Vector3d normal = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(0);
  if (!(centroid.norm() > 0)) return false;
  const Eigen::Vector3d sight = centroid.normalized();
  const Eigen::Vector3d mirrored = 2 * normal.dot(sight) * sight - normal;
  const Eigen::Quaterniond turn = Eigen::Quaterniond::FromTwoVectors(normal, mirrored);
  const Rigid3d about(turn, centroid - turn * centroid);
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (component >= 0 && static_cast<int>(c) != component) continue;
    const Block& b = graph.blocks[graph.components[c].block];
    if (b.kind == BlockKind::kPose) {
      start->poses[b.index] = about * start->poses[b.index];
    } else {
      start->points[b.index] = about * start->points[b.index];
    }
  }
  return true;
}

bool Sound(const Solution& s) {
  return s.summary.converged && s.contradictions.empty() && s.invalid.empty();
}

// For each single point held by `distance == nominal` to three or more other single points:
// those points (its anchors). Three distances fix a point only up to its mirror image through
// the anchors' plane.
std::vector<std::vector<int>> DistanceAnchors(const ConstraintGraph& graph) {
  std::vector<std::vector<int>> anchors(graph.components.size());
  for (const Constraint& c : graph.constraints) {
    if (c.kind != "distance ==") continue;
    const std::vector<int> ends = ConstraintComponents(graph, c);
    if (ends.size() != 2 || graph.components[ends[0]].rigid || graph.components[ends[1]].rigid) {
      continue;
    }
    for (int k = 0; k < 2; ++k) {
      std::vector<int>& list = anchors[ends[k]];
      if (std::find(list.begin(), list.end(), ends[1 - k]) == list.end()) {
        list.push_back(ends[1 - k]);
      }
    }
  }
  for (std::vector<int>& list : anchors) {
    if (list.size() < 3) list.clear();
  }
  return anchors;
}

// `start` with single point `component` mirrored through the plane its anchors lie nearest to.
// False when the anchors are nearly on one line (the point then turns about it: no mirror
// image) or the point lies in that plane.
bool Reflected(const ConstraintGraph& graph, const std::vector<int>& anchors, int component,
               double extent, Values* start) {
  const auto at = [&](int c) -> Eigen::Vector3d& {
    return start->points[graph.blocks[graph.components[c].block].index];
  };
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int a : anchors) centroid += at(a);
  centroid /= static_cast<double>(anchors.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (int a : anchors) scatter += (at(a) - centroid) * (at(a) - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  if (!(eigen.eigenvalues()(1) > 1e-6 * eigen.eigenvalues()(2))) return false;
  const Eigen::Vector3d normal = eigen.eigenvectors().col(0);
  Eigen::Vector3d& p = at(component);
  const double height = (p - centroid).dot(normal);
  if (!(std::abs(height) > 1e-3 * extent)) return false;
  p -= 2 * height * normal;
  return true;
}

// The answer's discrete neighbours: its mirror images about the line of sight, whole and part
// by part, and each single point mirrored through its anchors' plane where its image stays
// inside the gate (seen along its line of sight, the two places project nearly alike: the
// ambiguity one camera leaves; elsewhere the measurement decides).
std::vector<Values> Flips(const ConstraintGraph& graph, const MeasurementSet& set,
                          const std::vector<ResolvedLabel>& labels,
                          const std::vector<std::vector<int>>& anchors, double extent,
                          const Values& at) {
  const double gate = ChiSquareQuantile(1 - 1e-9, 2);
  std::vector<Values> out;
  for (int c = -1; c < static_cast<int>(graph.components.size()); ++c) {
    if (c >= 0 && (!graph.components[c].rigid || graph.components.size() == 1)) continue;
    Values mirrored = at;
    if (Mirrored(graph, labels, c, &mirrored)) out.push_back(std::move(mirrored));
  }
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (anchors[c].empty()) continue;
    Values reflected = at;
    if (!Reflected(graph, anchors[c], static_cast<int>(c), extent, &reflected)) continue;
    const bool seen_elsewhere =
        std::any_of(labels.begin(), labels.end(), [&](const ResolvedLabel& r) {
          return r.component == static_cast<int>(c) &&
                 !(NormalisedSquare(graph, set, r, reflected) <= gate);
        });
    if (!seen_elsewhere) out.push_back(std::move(reflected));
  }
  return out;
}

// From image measurements a solve can end in one of several minima (a near-planar part or the
// whole object mirrored about the line of sight, a point on the far side of its anchors). The
// other closed-form start (the nominal geometry moved as one body) and the mirror images of
// both starts, whole and part by part, are solved too. Then, from the best minimum so far, each
// of its discrete neighbours (Flips) is solved, and the best of them taken while it fits
// better: the lamp's minima differ by one point or one arm at a time, and the answer's mirror
// images alone left 3 of 50 answers on a worse minimum than the truth's, none said. The best fit
// becomes the solution and the other distinct minima that the fit test does not reject its
// alternatives.
void ExploreStarts(const ConstraintGraph& graph, const MeasurementSet& set,
                   const SolveOptions& options, const std::vector<ResolvedLabel>& used,
                   Solution* solution) {
  const Values each = ClosedFormStart(graph, set, used, options, true);
  const Values whole = ClosedFormStart(graph, set, used, options, false);
  std::vector<Values> starts = {whole};
  for (const Values* base : {&each, &whole}) {
    Values mirrored = *base;
    if (Mirrored(graph, used, -1, &mirrored)) starts.push_back(mirrored);
  }
  for (size_t c = 0; c < graph.components.size() && graph.components.size() > 1; ++c) {
    if (!graph.components[c].rigid) continue;
    Values mirrored = each;
    if (Mirrored(graph, used, static_cast<int>(c), &mirrored)) starts.push_back(mirrored);
  }
  // The best: the lowest chi-square among the sound ones.
  auto better = [](const Solution& a, const Solution& b) {
    return a.analysis.fit.chi2 < b.analysis.fit.chi2;
  };
  std::vector<Solution> found;
  const auto take_best = [&](std::vector<Solution>::iterator from) {
    bool improved = false;
    for (auto other = from; other != found.end(); ++other) {
      if (Sound(*solution) && !better(*other, *solution)) continue;
      // (A start that ends in the same minimum is no step: 0.01 in chi-square is noise.)
      improved = improved || !Sound(*solution) ||
                 other->analysis.fit.chi2 < solution->analysis.fit.chi2 - 0.01;
      std::swap(solution->state, other->state);
      std::swap(solution->summary, other->summary);
      std::swap(solution->analysis, other->analysis);
      std::swap(solution->contradictions, other->contradictions);
      std::swap(solution->invalid, other->invalid);
      std::swap(solution->fits, other->fits);
    }
    return improved;
  };
  const auto solve_from = [&](const std::vector<Values>& list) {
    const size_t before = found.size();
    for (const Values& start : list) {
      Solution other;
      other.extent = solution->extent;
      SolveLabelled(graph, set, options, used, &other, &start);
      if (!Sound(other)) continue;
      other.fits = other.analysis.fit.p_value >= options.min_p_value;
      found.push_back(std::move(other));
    }
    return take_best(found.begin() + static_cast<std::ptrdiff_t>(before));
  };
  solve_from(starts);
  const std::vector<std::vector<int>> anchors = DistanceAnchors(graph);
  constexpr int kMaxFlipRounds = 4;
  for (int round = 0; round < kMaxFlipRounds && Sound(*solution); ++round) {
    if (!solve_from(Flips(graph, set, used, anchors, solution->extent, solution->state.mean))) {
      break;
    }
  }
  // (`found` now holds every sound answer but the best, the first one included if replaced.)
  std::sort(found.begin(), found.end(), better);
  for (const Solution& other : found) {
    if (!Sound(other) || !other.fits) continue;
    if (!Distinct(graph, other.state.mean, solution->state, solution->extent)) continue;
    const bool seen = std::any_of(found.begin(), found.begin() + (&other - found.data()),
                                  [&](const Solution& earlier) {
                                    return Sound(earlier) && earlier.fits &&
                                           Distinct(graph, earlier.state.mean, solution->state,
                                                    solution->extent) &&
                                           !Distinct(graph, other.state.mean, earlier.state,
                                                     solution->extent);
                                  });
    if (!seen) solution->alternatives.push_back({other.state.mean, other.analysis.fit});
  }
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

}  // namespace

bool Distinct(const ConstraintGraph& graph, const Values& other, const GaussianState& best,
              double extent) {
  for (const Component& c : graph.components) {
    const Block& block = graph.blocks[c.block];
    const int o = block.tangent_offset;
    if (block.kind == BlockKind::kPose) {
      const Rigid3d& pa = other.poses[block.index];
      const Rigid3d& pb = best.mean.poses[block.index];
      const double turn_sigma =
          std::sqrt(std::max(0.0, best.covariance.block<3, 3>(o, o).eigenvalues().real().maxCoeff()));
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
  RequireEstimable(graph);
  Solution solution;
  solution.labels = ResolveLabels(graph, set);
  solution.extent = ModelExtent(graph);
  std::vector<ResolvedLabel> used = solution.labels;
  const size_t max_rejected = used.size() / 5;
  const double gate_3d = ChiSquareQuantile(1 - 1e-9, 3), gate_2d = ChiSquareQuantile(1 - 1e-9, 2);
  // Outliers are judged at the best of the minima, not at the first one found.
  const bool image = std::any_of(used.begin(), used.end(), [&](const ResolvedLabel& r) {
    return !set.points[r.measurement].is_3d;
  });
  const auto solve = [&] {
    SolveLabelled(graph, set, options, used, &solution);
    solution.fits = solution.analysis.fit.p_value >= options.min_p_value;
    solution.alternatives.clear();
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
      const auto label = std::find_if(solution.labels.begin(), solution.labels.end(),
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
