#include "cfuse/interp/parametric.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/jet.h"
#include "kinematic_forest.h"

namespace cfuse {
namespace {

using internal::Configuration;
using internal::Difference;
using internal::Forest;
using internal::ForestRules;
using internal::FromPoses;
using internal::Influence;
using internal::Influences;
using internal::Placement;
using internal::Retract;
using internal::Twists;

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string Unsupported(const ConstraintGraph& g, Forest* forest) {
  return internal::BuildForest(g, ForestRules::kEveryConstraint, forest);
}

// One labelled measurement, resolved.
struct Observation {
  int component = -1;
  Eigen::Vector3d local;  // the feature point in component coordinates
  const MeasuredPoint* measured = nullptr;
  Eigen::MatrixXd whiten;  // L⁻¹ with covariance L Lᵀ
};

// Whitened residuals r (measured - predicted is -r) and, if J is not null, their Jacobian.
void Linearise(const ConstraintGraph& g, const Forest& f, const MeasurementSet& set,
               const std::vector<Observation>& obs,
               const std::vector<std::vector<Influence>>& influence, const Configuration& x,
               Eigen::VectorXd* r, Eigen::MatrixXd* J) {
  const Placement place = internal::Place(g, f, x);
  Eigen::MatrixXd T;
  if (J) T = Twists(g, f, place, x);
  int rows = 0;
  for (const Observation& o : obs) rows += o.measured->is_3d ? 3 : 2;
  r->resize(rows);
  if (J) J->setZero(rows, f.size);
  int row = 0;
  for (const Observation& o : obs) {
    const Eigen::Vector3d p = place.world_from_component[o.component] * o.local;
    Eigen::Matrix<double, Eigen::Dynamic, 3> dr_dp;  // d residual / d p, before whitening
    Eigen::VectorXd raw;
    if (o.measured->is_3d) {
      raw = p - o.measured->xyz;
      dr_dp = Eigen::Matrix3d::Identity();
    } else {
      Vector3<Jet> pj;
      for (int i = 0; i < 3; ++i) pj[i] = Jet(p[i], JetDerivatives::Unit(i));
      const Eigen::Matrix<Jet, 2, 1> uv = set.camera->Project<Jet>(pj);
      raw = Eigen::Vector2d(uv[0].value(), uv[1].value()) - o.measured->uv;
      dr_dp.resize(2, 3);
      for (int i = 0; i < 2; ++i) dr_dp.row(i) = uv[i].derivatives().head<3>().transpose();
    }
    const int d = static_cast<int>(raw.size());
    r->segment(row, d) = o.whiten * raw;
    if (J) {
      const Eigen::MatrixXd A = o.whiten * dr_dp;
      for (const Influence& in : influence[o.component]) {
        const auto t = T.col(in.twist);
        const Eigen::Vector3d dp = t.head<3>().cross(p) + t.tail<3>();
        J->block(row, in.parameter, d, 1) += in.multiplier * (A * dp);
      }
    }
    row += d;
  }
}

std::vector<Observation> Observations(const ConstraintGraph& graph, const MeasurementSet& set,
                                      const std::vector<ResolvedLabel>& labels) {
  std::vector<Observation> obs;
  for (const ResolvedLabel& l : labels) {
    Observation o;
    o.component = l.component;
    o.local = graph.components[l.component].points[l.feature].position;
    o.measured = &set.points[l.measurement];
    const Eigen::MatrixXd cov =
        o.measured->is_3d ? Eigen::MatrixXd(o.measured->cov3) : Eigen::MatrixXd(o.measured->cov2);
    const Eigen::LLT<Eigen::MatrixXd> llt(cov);
    if (llt.info() != Eigen::Success) {
      throw InputError(o.measured->where, "the measurement's covariance is not positive definite");
    }
    o.whiten = llt.matrixL().solve(Eigen::MatrixXd::Identity(cov.rows(), cov.cols()));
    obs.push_back(std::move(o));
  }
  return obs;
}

// The components' poses at x with their slacks matched, and G = d(their tangent
// coordinates)/d(parameters).
Values PosesAt(const ConstraintGraph& graph, const Forest& f,
               const std::vector<std::vector<Influence>>& influence, const Configuration& x,
               Eigen::MatrixXd* G) {
  Values values = graph.nominal;
  internal::ComponentPoses(graph, f, influence, x, &values, G);
  MatchSlacks(graph, &values);
  return values;
}

// The forest and its layout, or an InputError at the model.
Forest Prepare(const ConstraintGraph& graph, const ParametricOptions& options, double extent) {
  Forest f;
  if (const std::string why = Unsupported(graph, &f); !why.empty()) {
    throw InputError(SourceLocation(graph.source),
                     fmt::format("no parametric form for model '{}': {}", graph.name, why));
  }
  internal::LayoutParameters(graph, options.prior_extent_factor * extent,
                             options.prior_rotation_sigma, &f);
  return f;
}

}  // namespace

ParametricEvaluation EvaluateParametric(const ConstraintGraph& graph, const MeasurementSet& set,
                                        const Values& start, const Eigen::VectorXd& delta) {
  const Forest f = Prepare(graph, {}, ModelExtent(graph));
  Configuration x = FromPoses(graph, f, start);
  if (delta.size() > 0) {
    CFUSE_CHECK_MSG(delta.size() == f.size, "a delta for every parameter");
    Retract(graph, f, delta, &x);
  }
  const std::vector<ResolvedLabel> labels = ResolveLabels(graph, set);
  const std::vector<Observation> obs = Observations(graph, set, labels);
  const auto influence = Influences(graph, f);
  ParametricEvaluation out;
  Linearise(graph, f, set, obs, influence, x, &out.residual, &out.jacobian);
  out.values = PosesAt(graph, f, influence, x, &out.pose_jacobian);
  return out;
}

std::string ParametricUnsupported(const ConstraintGraph& graph) {
  return Unsupported(graph, nullptr);
}

ParametricSolution SolveParametric(const ConstraintGraph& graph, const MeasurementSet& set,
                                   const ParametricOptions& options) {
  CheckGraph(graph);
  CheckMeasurementSet(set);
  ParametricSolution out;
  Solution& solution = out.solution;
  solution.extent = ModelExtent(graph);
  const Forest f = Prepare(graph, options, solution.extent);
  solution.labels = ResolveLabels(graph, set);
  const int n = f.size;

  // The start: the components' closed-form poses (or the guess), read as parameters.
  Values start = ClosedFormStart(graph, set, solution.labels);
  if (options.guess) ApplyGuess(graph, *options.guess, &start);
  const Configuration prior = FromPoses(graph, f, start);
  Configuration x = prior;

  const std::vector<Observation> obs = Observations(graph, set, solution.labels);
  const auto influence = Influences(graph, f);
  Eigen::VectorXd w2(n);  // WᵀW
  for (int i = 0; i < n; ++i) w2[i] = 1.0 / (f.prior_sigma[i] * f.prior_sigma[i]);

  // The joint variable of parameter i when it is bounded, else null.
  std::vector<int> bounded_joint(n, -1);
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k >= 0 && HasJointVariable(graph.joints[j].type) &&
        (f.lower[k] > -kInf || f.upper[k] < kInf)) {
      bounded_joint[k] = j;
    }
  }
  Eigen::VectorXd r;
  Eigen::MatrixXd J, H;
  std::vector<bool> held(n, false);
  Eigen::VectorXd sigma = Eigen::VectorXd::Zero(n);
  for (int it = 0; it < options.max_iterations; ++it) {
    Linearise(graph, f, set, obs, influence, x, &r, &J);
    if (!r.allFinite() || !J.allFinite()) break;  // e.g. a point behind the camera
    H = J.transpose() * J;
    H.diagonal() += w2;
    const Eigen::VectorXd b = -J.transpose() * r - w2.cwiseProduct(Difference(graph, f, prior, x));
    // Projected Gauss-Newton: variables whose step would leave their limits are held on them
    // and the rest solved again, until no step leaves.
    std::fill(held.begin(), held.end(), false);
    Eigen::VectorXd step = Eigen::VectorXd::Zero(n);
    Eigen::MatrixXd H_free_inverse;
    std::vector<int> free;
    for (int round = 0; round <= n; ++round) {
      free.clear();
      Eigen::VectorXd fixed_step = Eigen::VectorXd::Zero(n);
      for (int i = 0; i < n; ++i) {
        if (!held[i]) {
          free.push_back(i);
        } else {
          const int j = bounded_joint[i];
          fixed_step[i] = std::clamp(x.q[j] + step[i], f.lower[i], f.upper[i]) - x.q[j];
        }
      }
      const int nf = static_cast<int>(free.size());
      Eigen::MatrixXd Hf(nf, nf);
      Eigen::VectorXd bf(nf);
      const Eigen::VectorXd coupling = H * fixed_step;
      for (int a = 0; a < nf; ++a) {
        bf[a] = b[free[a]] - coupling[free[a]];
        for (int c = 0; c < nf; ++c) Hf(a, c) = H(free[a], free[c]);
      }
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(Hf);
      const Eigen::VectorXd sf = ldlt.solve(bf);
      H_free_inverse = ldlt.solve(Eigen::MatrixXd::Identity(nf, nf));
      step = fixed_step;
      for (int a = 0; a < nf; ++a) step[free[a]] = sf[a];
      bool left = false;
      for (int i : free) {
        const int j = bounded_joint[i];
        if (j < 0) continue;
        if (x.q[j] + step[i] > f.upper[i] || x.q[j] + step[i] < f.lower[i]) {
          held[i] = true;
          left = true;
        }
      }
      if (!left) break;
    }
    for (int i = 0; i < n; ++i) {
      if (held[i])
        step[i] = std::clamp(x.q[bounded_joint[i]] + step[i], f.lower[i], f.upper[i]) -
                  x.q[bounded_joint[i]];
    }
    sigma.setZero();
    for (size_t a = 0; a < free.size(); ++a)
      sigma[free[a]] = std::sqrt(std::max(0.0, H_free_inverse(a, a)));
    Retract(graph, f, step, &x);
    out.iterations = it + 1;
    bool small = true;
    for (int i = 0; i < n; ++i) {
      if (!held[i] && std::abs(step[i]) > options.step_tolerance * sigma[i]) small = false;
    }
    out.covariance = Eigen::MatrixXd::Zero(n, n);
    for (size_t a = 0; a < free.size(); ++a)
      for (size_t c = 0; c < free.size(); ++c)
        out.covariance(free[a], free[c]) = H_free_inverse(a, c);
    if (small) {
      out.converged = true;
      break;
    }
  }
  // Lowe's residual variance at the solution; the parameters and the components' poses.
  Linearise(graph, f, set, obs, influence, x, &r, nullptr);
  const int m = static_cast<int>(r.size());
  out.residual_variance =
      m > n ? r.squaredNorm() / (m - n) : std::numeric_limits<double>::quiet_NaN();
  out.parameter_names = f.names;
  out.at_limit = held;
  out.parameters = Eigen::VectorXd::Zero(n);
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k >= 0 && HasJointVariable(graph.joints[j].type)) out.parameters[k] = x.q[j];
  }
  if (out.covariance.rows() != n) out.covariance = Eigen::MatrixXd::Zero(n, n);

  GaussianState& state = solution.state;
  state.blocks = graph.blocks;
  Eigen::MatrixXd G;
  state.mean = PosesAt(graph, f, influence, x, &G);
  state.covariance = G * out.covariance * G.transpose();
  state.covariance = 0.5 * (state.covariance + state.covariance.transpose()).eval();
  state.prior_variance = state.covariance.diagonal();
  solution.summary.passes = out.iterations;
  solution.summary.converged = out.converged;
  // The same fit as solve's, from the same whitened residuals (n parameters, none free).
  Fit& fit = solution.analysis.fit;
  fit.chi2 = r.squaredNorm();
  fit.residuals = m;
  fit.dof = std::max(0, m - n);
  fit.p_value = fit.dof > 0 ? 1 - ChiSquareCdf(fit.chi2, fit.dof) : 1.0;
  solution.analysis.state_dim = solution.analysis.model_dof = solution.analysis.determined = n;
  solution.fits = fit.p_value >= SolveOptions{}.min_p_value;
  for (const Constraint& c : graph.constraints) {
    Eigen::VectorXd residual;
    EvaluateResidual(*c.residual, graph.blocks, c.blocks, state.mean, &residual, nullptr);
    solution.summary.max_constraint_residual =
        std::max(solution.summary.max_constraint_residual, residual.lpNorm<Eigen::Infinity>());
  }
  return out;
}

}  // namespace cfuse
