// Ceres on the parametric problem of a robot: a peer for constraint fusion in robot_sweep.
//
// The problem is the one Lowe's parametric form solves (cfuse/interp/parametric.h): each root
// component's pose and each joint's variable are the parameters, forward kinematics places
// every component, and every labelled 3D measurement gives a residual whitened by its
// covariance. Joint limits are bounds on the variables. Ceres minimises it by
// Levenberg-Marquardt, with automatic derivatives through the kinematic chain, from the same
// closed-form start as cfuse's solvers. It is built only where Ceres is installed, and only
// robot_sweep links it.
#pragma once

#include <string>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/measurement_set.h"
#include "cfuse/kernel/values.h"

namespace cfuse::bench {

struct CeresRobotResult {
  bool converged = false;  // Ceres reports convergence, and a usable solution
  Values values;           // every component's pose from the solution's kinematics
  int iterations = 0;
};

// Empty when the peer can write the model as root poses and joint variables: joints revolute,
// continuous, prismatic or fixed (mimics allowed), forming a forest of rigid components; else
// why not.
std::string CeresRobotUnsupported(const ConstraintGraph& graph);

// Solves from the labelled 3D points of `set` (labels as cfuse's solvers resolve them).
CeresRobotResult SolveWithCeres(const ConstraintGraph& graph, const MeasurementSet& set);

// The largest distance (m) between a model point placed by the peer's forward kinematics, with
// the root poses and joint variables read from `values`, and the same point placed by
// `values` itself: about 1e-15 when `values` satisfies every joint (a simulation's truth) and
// the peer's kinematics are the model's.
double CeresKinematicsError(const ConstraintGraph& graph, const Values& values);

}  // namespace cfuse::bench
