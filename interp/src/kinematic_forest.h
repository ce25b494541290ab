// A model's joints as a kinematic forest: each component placed by its root's pose and the
// joint variables on its way up, so that every joint of the forest holds by construction.
//
// Two users: Lowe's parametric estimator (parametric.h), which needs every constraint to be
// one the forest holds, and the solver with the forest's joints eliminated (reduced_solver.h),
// which leaves every other constraint (a loop's closing constraint, limits, distances) to be
// solved as constraint rows. (Models close loops with constraints: the model builder refuses a
// component that is the child of two joints, and the loaders a cycle of joints.)
//
// Parameters, in this order: per root component without a fixed pose, 6 in the chart of
// values.h (R Exp(δθ), t + δt); then per joint of the forest, by type: revolute, continuous,
// prismatic 1 (the joint variable; a mimic joint none: it follows its leader), spherical 3
// (R Exp(δθ)), planar 3, floating 6, fixed 0. Each parameter moves every component downstream
// of it rigidly, by a world twist (ω, v): a point p moves by ω × p + v.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/rigid3.h"
#include "cfuse/kernel/values.h"

namespace cfuse::internal {

// The kinematic forest of a model and where each parameter sits.
struct Forest {
  std::vector<int> parent_joint;           // per component: the joint placing it, or -1 (a root)
  std::vector<int> order;                  // joints, each after the one placing its parent
  std::vector<const Rigid3d*> fixed;       // per component: a root's fixed pose, or null
  std::vector<bool> held;                  // per constraint: held by construction
  std::vector<int> root_parameter;         // per component: offset of a free root's 6, or -1
  std::vector<int> joint_parameter;        // per joint: offset of its parameters, or -1
  std::vector<int> leader;                 // per joint: the independent joint its variable is
  std::vector<double> multiplier, offset;  // q = multiplier * q_leader + offset
  std::vector<std::string> names;          // per parameter
  std::vector<double> lower, upper;        // per parameter: bounds (±inf: none)
  std::vector<double> prior_sigma;         // per parameter
  int size = 0;
  // Twists: one per parameter, then one per mimic joint (its own axis, which its leader's
  // parameter turns by the multiplier).
  std::vector<int> mimic_twist;  // per joint: its twist column, or -1
  int twists = 0;
};

// Parameter `parameter` moves a component by `multiplier` x twist `twist`.
struct Influence {
  int parameter;
  double multiplier;
  int twist;
};

enum class ForestRules {
  // Lowe's parametric form: every joint in the forest, and every constraint a joint's own, its
  // limit, a mimic or a root's fixed pose.
  kEveryConstraint,
  // Every joint in the forest; every constraint the forest does not hold left to the caller.
  kJointsFirst,
};

// The forest's structure (parent joints, order, fixed roots, held constraints); empty when
// the model has one under `rules`, else why not, naming the first component, constraint or
// joint in the way.
std::string BuildForest(const ConstraintGraph& g, ForestRules rules, Forest* forest);

// The parameters' layout, names (unless not wanted), prior standard deviations and bounds.
void LayoutParameters(const ConstraintGraph& g, double position_sigma, double rotation_sigma,
                      Forest* f, bool names = true);

// The configuration: root poses, joint variables and the motions of multi-parameter joints.
struct Configuration {
  std::vector<Rigid3d> root;    // per component (roots only)
  std::vector<double> q;        // per joint (independent variable joints)
  std::vector<Rigid3d> motion;  // per joint (spherical, planar, floating)
};

// Forward kinematics, keeping each joint's frame on its parent in the world (A = world_from_
// parent * parent_from_joint) and the moved frame B = A * Motion.
struct Placement {
  std::vector<Rigid3d> world_from_component;
  std::vector<Rigid3d> A, B;  // per joint
};
Placement Place(const ConstraintGraph& g, const Forest& f, const Configuration& x);

// The world twists (ω, v) of every parameter: a point moved by parameter i moves by
// ω_i × p + v_i. Columns of a 6 x f.twists matrix [ω; v].
Eigen::MatrixXd Twists(const ConstraintGraph& g, const Forest& f, const Placement& p,
                       const Configuration& x);

// Per component, the parameters that move it and by how much (a mimic's leader by its
// multiplier): the root's six and every joint's on the way up.
std::vector<std::vector<Influence>> Influences(const ConstraintGraph& g, const Forest& f);

// x ⊞ δ.
void Retract(const ConstraintGraph& g, const Forest& f, const Eigen::VectorXd& d, Configuration* x);

// δ with to = from ⊞ δ (to first order for the rotations, which is all the prior term needs).
Eigen::VectorXd Difference(const ConstraintGraph& g, const Forest& f, const Configuration& from,
                           const Configuration& to);

// Parameters from component poses that need not meet the joints (the closed-form starts):
// each root where its start is, each joint's motion read off its two components' starts,
// joint variables on the branch centred on their limits and clamped into them.
Configuration FromPoses(const ConstraintGraph& g, const Forest& f, const Values& start);

// The components' poses at x written into `values` (its other blocks untouched), and G = d(their
// tangent coordinates)/d(parameters), graph.tangent_dim() x f.size, zero in other blocks' rows:
// parameter i turns component c, in its chart, by R_cᵀ ω_i and moves its origin by
// ω_i × t_c + v_i.
void ComponentPoses(const ConstraintGraph& graph, const Forest& f,
                    const std::vector<std::vector<Influence>>& influence, const Configuration& x,
                    Values* values, Eigen::MatrixXd* G);

}  // namespace cfuse::internal
