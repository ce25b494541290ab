// Lowe's parametric estimator (Lowe 1991; 1992, equation 1): the baseline that constraint
// fusion is measured against on articulated models.
//
// Where a model's joints form a forest, its configuration is a few numbers: each root
// component's pose and each joint's own variables. Forward kinematics maps them to every
// component's pose, so every joint holds by construction, and Gauss-Newton runs on those
// numbers alone, stabilised by prior variances:
//   (JᵀJ + WᵀW) x = Jᵀe + WᵀW (x0 - xk),   W = diag(1/σ_i),
// J and e whitened by the measurements' noise, x the correction to the current estimate xk,
// x0 the prior mean (the start). At the first iteration xk = x0 and this is Lowe's equation
// (1). Lowe stabilises every later iteration towards the current estimate instead (the right
// side stays Jᵀe), a Levenberg-Marquardt damping that ends at the data's least squares, not
// at the posterior; with a prior we keep the maximum-a-posteriori form, which is also what
// the iterated Kalman update computes. The covariance is (JᵀJ + WᵀW)⁻¹ at the solution; it is
// mapped to the components' poses for results.
//
// Parameters, in this order: per root component without a fixed pose, 6 in the chart of
// values.h (R Exp(δθ), t + δt); then per joint, by type: revolute, continuous, prismatic 1
// (the joint variable; a mimic joint none: it follows its leader), spherical 3 (R Exp(δθ)),
// planar 3 (the angle about the axis, then the displacements along the axis's two normals),
// floating 6, fixed 0. Each parameter moves every component downstream of it rigidly, by a
// world twist (ω, v): a point p moves by ω × p + v. The measurement Jacobians are therefore
// geometric, as in robotics' manipulator Jacobian, rather than automatically differentiated
// (the tests check them against finite differences).
//
// Limits: Lowe's method has none. Here a limited joint variable (or the leader of a limited
// mimic joint) is kept inside by projected Gauss-Newton: a step that would leave the limits
// holds the variable on its limit, with no variance, and it is freed again when the
// unconstrained step points back inside.
//
// Models it cannot represent (ParametricUnsupported says which part): single-point
// components; constraints other than joints, joint limits, mimics and fully fixed root poses
// (distances, parallels, ranges between points); a component that is the child of two joints
// (a closed loop).
#pragma once

#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/measurement_set.h"

namespace cfuse {

struct ParametricOptions {
  int max_iterations = 50;
  double step_tolerance = 1e-3;  // converged: every step below this many posterior sigmas
  // Prior standard deviations about the start, as Solve's (solve.h): positions, prismatic and
  // planar displacements `prior_extent_factor` x the model's extent; rotations and angles
  // `prior_rotation_sigma`.
  double prior_extent_factor = 10.0;
  double prior_rotation_sigma = 1.0;          // rad
  const PoseSet* guess = nullptr;             // starting poses by name, as Solve's
};

struct ParametricSolution {
  // The components' poses with their covariance and the labels, as Solve returns them, so
  // that results and joint estimates read the same way (summary.passes: iterations).
  Solution solution;
  std::vector<std::string> parameter_names;  // "base.rx" ... "base.tz", "joint", "ball.rx", ...
  Eigen::VectorXd parameters;  // joint variables as values; pose parameters as their chart's 0
  Eigen::MatrixXd covariance;  // of the parameters, in their charts at the solution
  std::vector<bool> at_limit;  // per parameter: held on a limit
  int iterations = 0;
  bool converged = false;
  // Lowe's residual test, σ² = |e|² / (m - n) with e whitened: about 1 when the data fit the
  // model within their stated noise (NaN when m <= n).
  double residual_variance = 0;
};

// Empty when the model can be written in root poses and joint variables; else why not,
// naming the first component, constraint or joint in the way.
std::string ParametricUnsupported(const ConstraintGraph& graph);

// Throws InputError at the model when ParametricUnsupported is not empty, and as ResolveLabels
// for the measurements' labels.
ParametricSolution SolveParametric(const ConstraintGraph& graph, const MeasurementSet& set,
                                   const ParametricOptions& options = {});

// The parametric form's pieces at one configuration, for tests: `start` (component poses,
// read as parameters as SolveParametric reads its start) moved by `delta` in the parameters'
// charts. `residual`: the labelled measurements' whitened residuals (predicted - measured);
// `jacobian`: their derivative in the charts at that configuration; `values`: its component
// poses; `pose_jacobian`: their tangent coordinates' derivative (values.h's chart).
struct ParametricEvaluation {
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;
  Values values;
  Eigen::MatrixXd pose_jacobian;
};
ParametricEvaluation EvaluateParametric(const ConstraintGraph& graph, const MeasurementSet& set,
                                        const Values& start, const Eigen::VectorXd& delta);

}  // namespace cfuse
