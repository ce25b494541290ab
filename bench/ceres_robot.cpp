#include "bench/ceres_robot.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "cfuse/interp/parametric.h"
#include "cfuse/interp/solve.h"

namespace cfuse::bench {
namespace {

template <typename T>
using Vector3 = Eigen::Matrix<T, 3, 1>;

template <typename T>
struct Pose {
  Eigen::Quaternion<T> rotation;
  Vector3<T> translation;
};

template <typename T>
Pose<T> Compose(const Pose<T>& a_from_b, const Rigid3d& b_from_c) {
  return {a_from_b.rotation * b_from_c.rotation.cast<T>(),
          a_from_b.rotation * b_from_c.translation.cast<T>() + a_from_b.translation};
}

// Pose * Motion(q) for a joint with a variable (JointMotion's convention: a turn about the axis
// through the joint frame's origin, or a slide along it).
template <typename T>
Pose<T> Move(const Pose<T>& a, JointType type, const Eigen::Vector3d& axis, const T& q) {
  if (type == JointType::kPrismatic) {
    return {a.rotation, a.rotation * (axis.cast<T>() * q) + a.translation};
  }
  using std::cos;
  using std::sin;
  const T half = q / T(2);
  const Vector3<T> v = axis.cast<T>() * sin(half);
  return {a.rotation * Eigen::Quaternion<T>(cos(half), v.x(), v.y(), v.z()), a.translation};
}

// A chain written as steps: a constant transform, then (for a joint with a variable) its
// motion. Consecutive constants are multiplied out once (a link's child_from_joint⁻¹ with the
// next joint's parent_from_joint; fixed joints whole), so the automatic derivatives go through
// one constant and one motion per joint with a variable.
struct Step {
  Rigid3d before;
  int joint = -1;  // its motion follows `before`; -1: none (the chain's last constant)
};

std::vector<Step> Steps(const ConstraintGraph& g, const std::vector<int>& chain) {
  std::vector<Step> steps;
  Rigid3d pending;
  for (int j : chain) {
    const Joint& joint = g.joints[j];
    pending = pending * joint.parent_from_joint;
    if (HasJointVariable(joint.type)) {
      steps.push_back({pending, j});
      pending = Rigid3d();
    }
    pending = pending * joint.child_from_joint.Inverse();
  }
  steps.push_back({pending, -1});
  return steps;
}

// The forest: for each component its root (an index into `roots`) and the steps from the
// root's pose to its own, and each joint's variable (its leader's for a mimic).
struct Forest {
  std::vector<int> roots;                // root components
  std::vector<int> root;                 // per component: its root, into `roots`
  std::vector<std::vector<Step>> steps;  // per component
  std::vector<int> variable;             // per joint: variable index, or -1 (fixed)
  std::vector<int> variable_joint;       // per variable: its joint
};

Forest MakeForest(const ConstraintGraph& g) {
  Forest f;
  const int nc = static_cast<int>(g.components.size());
  std::vector<int> placed_by(nc, -1);
  for (size_t j = 0; j < g.joints.size(); ++j) placed_by[g.joints[j].child] = static_cast<int>(j);
  std::vector<int> root_component(nc);
  f.steps.resize(nc);
  for (int c = 0; c < nc; ++c) {
    std::vector<int> chain;  // joints from the root down
    int at = c;
    while (placed_by[at] >= 0) {
      chain.push_back(placed_by[at]);
      at = g.joints[placed_by[at]].parent;
    }
    std::reverse(chain.begin(), chain.end());
    f.steps[c] = Steps(g, chain);
    root_component[c] = at;
    if (at == c) f.roots.push_back(c);
  }
  for (int c = 0; c < nc; ++c) {
    f.root.push_back(static_cast<int>(std::find(f.roots.begin(), f.roots.end(), root_component[c]) -
                                      f.roots.begin()));
  }
  f.variable.assign(g.joints.size(), -1);
  for (size_t j = 0; j < g.joints.size(); ++j) {
    if (HasJointVariable(g.joints[j].type) && !g.joints[j].mimic) {
      f.variable[j] = static_cast<int>(f.variable_joint.size());
      f.variable_joint.push_back(static_cast<int>(j));
    }
  }
  for (size_t j = 0; j < g.joints.size(); ++j) {
    if (g.joints[j].mimic) f.variable[j] = f.variable[g.joints[j].mimic->leader];
  }
  return f;
}

// The joint's variable where `values` puts its parent and child (the follower's own value for a
// mimic: the caller maps it to its leader's).
double ReadVariable(const ConstraintGraph& g, const Joint& joint, const Values& values) {
  const auto pose = [&](int c) { return values.poses[g.blocks[g.components[c].block].index]; };
  const Rigid3d motion = (pose(joint.parent) * joint.parent_from_joint).Inverse() *
                         (pose(joint.child) * joint.child_from_joint);
  if (joint.type == JointType::kPrismatic) return motion.translation.dot(joint.axis);
  const Eigen::Quaterniond& r = motion.rotation;
  // (A quaternion and its negative are one turn: the angle in (-π, π].)
  return std::remainder(2 * std::atan2(r.vec().dot(joint.axis), r.w()), 2 * M_PI);
}

// The chain's end from its root's pose `x`; `q(i)`: the variable of step i's joint (its
// leader's for a mimic, mapped here).
template <typename T, typename Variable>
Pose<T> Through(const ConstraintGraph& g, const std::vector<Step>& steps, Pose<T> x,
                const Variable& q) {
  for (size_t i = 0; i < steps.size(); ++i) {
    x = Compose(x, steps[i].before);
    if (steps[i].joint < 0) continue;
    const Joint& joint = g.joints[steps[i].joint];
    T value = q(i);
    if (joint.mimic) value = T(joint.mimic->multiplier) * value + T(joint.mimic->offset);
    x = Move(x, joint.type, joint.axis, value);
  }
  return x;
}

// The labelled points of one component: parameter blocks (the root's rotation as w, x, y, z;
// its translation; then the distinct joint variables of the chain), residuals L⁻¹ (x - z) with
// each measurement's covariance L Lᵀ. One block per component, as its points share the chain.
struct ComponentResidual {
  const ConstraintGraph* g = nullptr;
  std::vector<Step> steps;
  std::vector<int> slot;  // per step: its variable's parameter block
  std::vector<Eigen::Vector3d> local, measured;
  std::vector<Eigen::Matrix3d> whiten;

  template <typename T>
  bool operator()(T const* const* p, T* out) const {
    const Pose<T> root{Eigen::Quaternion<T>(p[0][0], p[0][1], p[0][2], p[0][3]),
                       Vector3<T>(p[1][0], p[1][1], p[1][2])};
    const Pose<T> x = Through(*g, steps, root, [&](size_t i) { return p[slot[i]][0]; });
    const Eigen::Matrix<T, 3, 3> rotation = x.rotation.toRotationMatrix();
    for (size_t k = 0; k < local.size(); ++k) {
      const Vector3<T> e = rotation * local[k].cast<T>() + x.translation - measured[k].cast<T>();
      Eigen::Map<Vector3<T>> residual(out + 3 * k);
      residual = whiten[k].cast<T>() * e;
    }
    return true;
  }
};

struct Parameters {
  std::vector<std::array<double, 4>> rotation;     // per root (w, x, y, z)
  std::vector<std::array<double, 3>> translation;  // per root
  std::vector<double> q;                           // per variable
};

Parameters Read(const ConstraintGraph& g, const Forest& f, const Values& values) {
  Parameters p;
  for (int r : f.roots) {
    const Rigid3d& pose = values.poses[g.blocks[g.components[r].block].index];
    const Eigen::Quaterniond q = pose.rotation.normalized();
    p.rotation.push_back({q.w(), q.x(), q.y(), q.z()});
    p.translation.push_back({pose.translation.x(), pose.translation.y(), pose.translation.z()});
  }
  for (int j : f.variable_joint) p.q.push_back(ReadVariable(g, g.joints[j], values));
  return p;
}

// Every component's pose from the parameters, into `values`.
void Write(const ConstraintGraph& g, const Forest& f, const Parameters& p, Values* values) {
  for (size_t c = 0; c < g.components.size(); ++c) {
    const auto& r = p.rotation[f.root[c]];
    const auto& t = p.translation[f.root[c]];
    const Pose<double> start{Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized(),
                             Eigen::Vector3d(t[0], t[1], t[2])};
    const std::vector<Step>& steps = f.steps[c];
    const Pose<double> x =
        Through(g, steps, start, [&](size_t i) { return p.q[f.variable[steps[i].joint]]; });
    values->poses[g.blocks[g.components[c].block].index] = Rigid3d(x.rotation, x.translation);
  }
}

}  // namespace

std::string CeresRobotUnsupported(const ConstraintGraph& graph) {
  if (std::string why = ParametricUnsupported(graph); !why.empty()) return why;
  for (const Joint& j : graph.joints) {
    if (!HasJointVariable(j.type) && j.type != JointType::kFixed) {
      return fmt::format(
          "joint '{}' is {}: the peer writes revolute, continuous, prismatic and "
          "fixed joints only",
          j.name, JointTypeName(j.type));
    }
  }
  for (const Constraint& k : graph.constraints) {
    if (k.kind == ConstraintKind::kFixed) {
      return fmt::format("constraint '{}' fixes a pose: the peer has free roots only", k.name);
    }
  }
  return "";
}

CeresRobotResult SolveWithCeres(const ConstraintGraph& g, const MeasurementSet& set) {
  const Forest f = MakeForest(g);
  const std::vector<ResolvedLabel> labels = ResolveLabels(g, set);
  CeresRobotResult out;
  out.values = ClosedFormStart(g, set, labels);
  Parameters p = Read(g, f, out.values);

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::QuaternionManifold unit_quaternion;
  // Each component's residual, owned by its cost function once added.
  std::vector<ComponentResidual*> residual_of(g.components.size(), nullptr);
  for (const ResolvedLabel& l : labels) {
    const MeasuredPoint& m = set.points[l.measurement];
    if (!m.is_3d || l.feature < 0) continue;
    ComponentResidual*& r = residual_of[l.component];
    if (!r) {
      r = new ComponentResidual;
      r->g = &g;
      r->steps = f.steps[l.component];
    }
    r->local.push_back(g.components[l.component].points[l.feature].position);
    r->measured.push_back(m.xyz);
    r->whiten.push_back(m.cov3.llt().matrixL().solve(Eigen::Matrix3d::Identity()));
  }
  for (size_t c = 0; c < g.components.size(); ++c) {
    ComponentResidual* residual = residual_of[c];
    if (!residual) continue;
    // Derivatives two parameters at a time: the fastest stride of 1, 2, 4, 8 and 16 on the
    // PR2 and the Panda (0.97 against 1.35-2.7 ms a PR2 solve).
    auto* cost = new ceres::DynamicAutoDiffCostFunction<ComponentResidual, 2>(residual);
    std::vector<double*> blocks = {p.rotation[f.root[c]].data(), p.translation[f.root[c]].data()};
    cost->AddParameterBlock(4);
    cost->AddParameterBlock(3);
    std::map<int, int> slot_of_variable;
    for (const Step& step : residual->steps) {
      const int v = step.joint >= 0 ? f.variable[step.joint] : -1;
      if (v >= 0 && !slot_of_variable.count(v)) {
        slot_of_variable[v] = static_cast<int>(blocks.size());
        blocks.push_back(&p.q[v]);
        cost->AddParameterBlock(1);
      }
      residual->slot.push_back(v >= 0 ? slot_of_variable[v] : -1);
    }
    cost->SetNumResiduals(3 * static_cast<int>(residual->local.size()));
    problem.AddResidualBlock(cost, nullptr, blocks);
  }
  for (size_t r = 0; r < f.roots.size(); ++r) {
    if (problem.HasParameterBlock(p.rotation[r].data())) {
      problem.SetManifold(p.rotation[r].data(), &unit_quaternion);
    }
  }
  for (size_t v = 0; v < f.variable_joint.size(); ++v) {
    const Joint& joint = g.joints[f.variable_joint[v]];
    if (!joint.limits || !problem.HasParameterBlock(&p.q[v])) continue;
    // Ceres starts inside its bounds: an angle read in (-π, π] first takes the turn that puts
    // it inside (a limit range of [-0.8, 3.9] holds 3.14, read as -3.14), then is clamped.
    if (joint.type == JointType::kRevolute) {
      for (const double turn : {2 * M_PI, -2 * M_PI}) {
        const double other = p.q[v] + turn;
        if ((p.q[v] < joint.limits->first || p.q[v] > joint.limits->second) &&
            other >= joint.limits->first && other <= joint.limits->second) {
          p.q[v] = other;
        }
      }
    }
    p.q[v] = std::clamp(p.q[v], joint.limits->first, joint.limits->second);
    problem.SetParameterLowerBound(&p.q[v], 0, joint.limits->first);
    problem.SetParameterUpperBound(&p.q[v], 0, joint.limits->second);
  }

  ceres::Solver::Options options;
  // Dense QR below a hundred parameters, a sparse Cholesky of the normal equations (SuiteSparse)
  // above: the faster of the two at each end of the sweep.
  options.linear_solver_type =
      p.q.size() + 7 * f.roots.size() < 100 ? ceres::DENSE_QR : ceres::SPARSE_NORMAL_CHOLESKY;
  options.num_threads = 1;
  options.max_num_iterations = 50;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  out.converged = summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
  out.iterations = static_cast<int>(summary.iterations.size());
  Write(g, f, p, &out.values);
  return out;
}

double CeresKinematicsError(const ConstraintGraph& g, const Values& values) {
  const Forest f = MakeForest(g);
  Values placed = values;
  Write(g, f, Read(g, f, values), &placed);
  double worst = 0;
  for (size_t c = 0; c < g.components.size(); ++c) {
    for (size_t i = 0; i < g.components[c].points.size(); ++i) {
      const int ci = static_cast<int>(c), fi = static_cast<int>(i);
      worst =
          std::max(worst, (ModelPoint(g, placed, ci, fi) - ModelPoint(g, values, ci, fi)).norm());
    }
  }
  return worst;
}

}  // namespace cfuse::bench
