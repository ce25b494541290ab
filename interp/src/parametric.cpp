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

namespace cfuse {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// The kinematic forest of a model and where each parameter sits.
struct Forest {
  std::vector<int> parent_joint;           // per component: the joint placing it, or -1 (a root)
  std::vector<int> order;                  // joints, each after the one placing its parent
  std::vector<const Rigid3d*> fixed;       // per component: a root's fixed pose, or null
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

std::string Unsupported(const ConstraintGraph& g, Forest* forest) {
  Forest f;
  const int nc = static_cast<int>(g.components.size());
  for (const Component& c : g.components) {
    if (!c.rigid) {
      return fmt::format(
          "component '{}' is a single point: only rigid components joined by "
          "joints have a parametric form",
          c.name);
    }
  }
  f.parent_joint.assign(nc, -1);
  for (size_t j = 0; j < g.joints.size(); ++j) {
    const Joint& joint = g.joints[j];
    if (f.parent_joint[joint.child] >= 0) {
      return fmt::format(
          "component '{}' is the child of joints '{}' and '{}': the joints form a "
          "closed loop",
          g.components[joint.child].name, g.joints[f.parent_joint[joint.child]].name, joint.name);
    }
    f.parent_joint[joint.child] = static_cast<int>(j);
  }
  // Every constraint must be a joint's own, its limit, a mimic, or a root's fixed pose.
  std::vector<bool> accounted(g.constraints.size(), false);
  for (const Joint& joint : g.joints) {
    for (int k :
         {joint.constraint, joint.limit_constraint, joint.mimic ? joint.mimic->constraint : -1}) {
      if (k >= 0) accounted[k] = true;
    }
  }
  f.fixed.assign(nc, nullptr);
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    if (accounted[k]) continue;
    const Constraint& c = g.constraints[k];
    // A root pose held by a `fixed:` entry (both position and orientation).
    const std::optional<Rigid3d>& fix = c.fixed_pose;
    int component = -1;
    for (int i = 0; i < nc; ++i) {
      if (fix && g.components[i].block == c.blocks[0]) component = i;
    }
    if (!fix || component < 0 || f.parent_joint[component] >= 0 || f.fixed[component]) {
      return fmt::format(
          "constraint '{}' ({}) is not a joint, a joint limit, a mimic or a fixed "
          "root pose: the parametric form cannot hold it",
          c.name, c.kind_name);
    }
    f.fixed[component] = &*fix;
  }
  // Joints from the roots down (breadth first); a cycle leaves some unreached.
  std::vector<std::vector<int>> children(nc);
  for (size_t j = 0; j < g.joints.size(); ++j)
    children[g.joints[j].parent].push_back(static_cast<int>(j));
  std::vector<int> queue;
  for (int c = 0; c < nc; ++c) {
    if (f.parent_joint[c] < 0) queue.push_back(c);
  }
  for (size_t i = 0; i < queue.size(); ++i) {
    for (int j : children[queue[i]]) {
      f.order.push_back(j);
      queue.push_back(g.joints[j].child);
    }
  }
  if (f.order.size() != g.joints.size()) {
    for (const Joint& joint : g.joints) {
      if (std::find(queue.begin(), queue.end(), joint.child) == queue.end()) {
        return fmt::format("joint '{}' is part of a cycle of joints", joint.name);
      }
    }
  }
  if (forest) *forest = std::move(f);
  return "";
}

// The parameters' layout, names, priors and bounds.
void Layout(const ConstraintGraph& g, const ParametricOptions& options, double extent, Forest* f) {
  const int nc = static_cast<int>(g.components.size());
  const double position_sigma = options.prior_extent_factor * extent;
  const double rotation_sigma = options.prior_rotation_sigma;
  auto add = [&](const std::string& name, double sigma) {
    f->names.push_back(name);
    f->prior_sigma.push_back(sigma);
    f->lower.push_back(-kInf);
    f->upper.push_back(kInf);
    return f->size++;
  };
  f->root_parameter.assign(nc, -1);
  for (int c = 0; c < nc; ++c) {
    if (f->parent_joint[c] >= 0 || f->fixed[c]) continue;
    const std::string& n = g.components[c].name;
    f->root_parameter[c] = f->size;
    for (const char* axis : {"rx", "ry", "rz"}) add(n + "." + axis, rotation_sigma);
    for (const char* axis : {"tx", "ty", "tz"}) add(n + "." + axis, position_sigma);
  }
  const int nj = static_cast<int>(g.joints.size());
  f->joint_parameter.assign(nj, -1);
  f->leader.resize(nj);
  f->multiplier.assign(nj, 1.0);
  f->offset.assign(nj, 0.0);
  for (int j = 0; j < nj; ++j) {
    // A mimic chain resolved to its independent joint (the builder keeps chains acyclic).
    int leader = j;
    while (g.joints[leader].mimic) {
      const JointMimic& m = *g.joints[leader].mimic;
      f->offset[j] += f->multiplier[j] * m.offset;
      f->multiplier[j] *= m.multiplier;
      leader = m.leader;
    }
    f->leader[j] = leader;
  }
  for (int j : f->order) {
    const Joint& joint = g.joints[j];
    if (joint.mimic) continue;
    const JointModel& model = ModelOf(joint.type);
    const int count = model.ParameterCount();
    if (count == 0) continue;
    f->joint_parameter[j] = f->size;
    for (const JointModel::Parameter& parameter : model.Parameters()) {
      add(*parameter.suffix ? joint.name + "." + parameter.suffix : joint.name,
          parameter.angle ? rotation_sigma : position_sigma);
    }
  }
  f->twists = f->size;
  f->mimic_twist.assign(nj, -1);
  for (int j = 0; j < nj; ++j) {
    if (g.joints[j].mimic && HasJointVariable(g.joints[j].type)) f->mimic_twist[j] = f->twists++;
  }
  // Bounds on each independent variable from its own limits and its mimics'.
  for (int j = 0; j < nj; ++j) {
    const Joint& joint = g.joints[j];
    if (!HasJointVariable(joint.type) || !joint.limits || joint.limit_constraint < 0) continue;
    const int p = f->joint_parameter[f->leader[j]];
    const double m = f->multiplier[j], o = f->offset[j];
    if (p < 0 || m == 0) continue;
    double lo = (joint.limits->first - o) / m, hi = (joint.limits->second - o) / m;
    if (m < 0) std::swap(lo, hi);
    f->lower[p] = std::max(f->lower[p], lo);
    f->upper[p] = std::min(f->upper[p], hi);
  }
}

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

Rigid3d Motion(const Joint& joint, const Forest& f, const Configuration& x, int j) {
  if (HasJointVariable(joint.type)) {
    const double q = f.multiplier[j] * x.q[f.leader[j]] + f.offset[j];
    return JointMotion(joint.type, joint.axis, q);
  }
  if (ModelOf(joint.type).ParameterCount() == 0) return Rigid3d();
  return x.motion[j];
}

Placement Place(const ConstraintGraph& g, const Forest& f, const Configuration& x) {
  Placement p;
  p.world_from_component.resize(g.components.size());
  p.A.resize(g.joints.size());
  p.B.resize(g.joints.size());
  for (size_t c = 0; c < g.components.size(); ++c) {
    if (f.parent_joint[c] < 0) p.world_from_component[c] = f.fixed[c] ? *f.fixed[c] : x.root[c];
  }
  for (int j : f.order) {
    const Joint& joint = g.joints[j];
    p.A[j] = p.world_from_component[joint.parent] * joint.parent_from_joint;
    p.B[j] = p.A[j] * Motion(joint, f, x, j);
    p.world_from_component[joint.child] = p.B[j] * joint.child_from_joint.Inverse();
    p.world_from_component[joint.child].rotation.normalize();
  }
  return p;
}

// The world twists (ω, v) of every parameter: a point moved by parameter i moves by
// ω_i × p + v_i. Columns of a 6 x n matrix [ω; v].
Eigen::MatrixXd Twists(const ConstraintGraph& g, const Forest& f, const Placement& p,
                       const Configuration& x) {
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(6, f.twists);
  auto rotation_about = [&](int column, const Eigen::Vector3d& omega, const Eigen::Vector3d& o) {
    T.col(column).head<3>() = omega;
    T.col(column).tail<3>() = o.cross(omega);  // ω × (p - o) = ω × p + o × ω
  };
  for (size_t c = 0; c < g.components.size(); ++c) {
    const int r = f.root_parameter[c];
    if (r < 0) continue;
    const Eigen::Matrix3d R = x.root[c].RotationMatrix();
    for (int i = 0; i < 3; ++i) {
      rotation_about(r + i, R.col(i), x.root[c].translation);
      T.col(r + 3 + i).tail<3>() = Eigen::Vector3d::Unit(i);
    }
  }
  for (int j : f.order) {
    const int k = f.mimic_twist[j] >= 0 ? f.mimic_twist[j] : f.joint_parameter[j];
    if (k < 0) continue;
    const Joint& joint = g.joints[j];
    ModelOf(joint.type).Twists(joint.axis, p.A[j], p.B[j], &T, k);
  }
  return T;
}

// Per component, the parameters that move it and by how much (a mimic's leader by its
// multiplier): the root's six and every joint's on the way up.
std::vector<std::vector<Influence>> Influences(const ConstraintGraph& g, const Forest& f) {
  std::vector<std::vector<Influence>> out(g.components.size());
  for (size_t c = 0; c < g.components.size(); ++c) {
    int at = static_cast<int>(c);
    while (f.parent_joint[at] >= 0) {
      const int j = f.parent_joint[at];
      const int leader = f.leader[j];
      const int k = f.joint_parameter[leader];
      if (k >= 0 && f.multiplier[j] != 0) {
        for (int i = 0; i < ModelOf(g.joints[leader].type).ParameterCount(); ++i) {
          out[c].push_back(
              {k + i, f.multiplier[j], f.mimic_twist[j] >= 0 ? f.mimic_twist[j] : k + i});
        }
      }
      at = g.joints[j].parent;
    }
    if (f.root_parameter[at] >= 0) {
      for (int i = 0; i < 6; ++i) {
        out[c].push_back({f.root_parameter[at] + i, 1.0, f.root_parameter[at] + i});
      }
    }
  }
  return out;
}

// x ⊞ δ.
void Retract(const ConstraintGraph& g, const Forest& f, const Eigen::VectorXd& d,
             Configuration* x) {
  for (size_t c = 0; c < g.components.size(); ++c) {
    const int r = f.root_parameter[c];
    if (r < 0) continue;
    Rigid3d& pose = x->root[c];
    pose.rotation =
        (pose.rotation * Eigen::Quaterniond(ExpSO3<double>(d.segment<3>(r)))).normalized();
    pose.translation += d.segment<3>(r + 3);
  }
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k < 0) continue;
    const Joint& joint = g.joints[j];
    ModelOf(joint.type).Retract(joint.axis, d.data() + k, &x->q[j], &x->motion[j]);
  }
}

// δ with to = from ⊞ δ (to first order for the rotations, which is all the prior term needs).
Eigen::VectorXd Difference(const ConstraintGraph& g, const Forest& f, const Configuration& from,
                           const Configuration& to) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(f.size);
  for (size_t c = 0; c < g.components.size(); ++c) {
    const int r = f.root_parameter[c];
    if (r < 0) continue;
    d.segment<3>(r) =
        LogSO3((from.root[c].rotation.conjugate() * to.root[c].rotation).toRotationMatrix());
    d.segment<3>(r + 3) = to.root[c].translation - from.root[c].translation;
  }
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k < 0) continue;
    const Joint& joint = g.joints[j];
    ModelOf(joint.type)
        .Difference(joint.axis, from.q[j], to.q[j], from.motion[j], to.motion[j], d.data() + k);
  }
  return d;
}

// Parameters from component poses that need not meet the joints (the closed-form starts):
// each root where its start is, each joint's motion read off its two components' starts,
// joint variables on the branch centred on their limits and clamped into them.
Configuration FromPoses(const ConstraintGraph& g, const Forest& f, const Values& start) {
  Configuration x;
  const int nc = static_cast<int>(g.components.size());
  const int nj = static_cast<int>(g.joints.size());
  x.root.resize(nc);
  x.q.assign(nj, 0.0);
  x.motion.resize(nj);
  auto pose = [&](int c) { return start.poses[g.blocks[g.components[c].block].index]; };
  for (int c = 0; c < nc; ++c) x.root[c] = pose(c);
  for (int j : f.order) {
    const Joint& joint = g.joints[j];
    const Rigid3d M = (pose(joint.parent) * joint.parent_from_joint).Inverse() *
                      (pose(joint.child) * joint.child_from_joint);
    if (HasJointVariable(joint.type)) {
      const JointValueFunction value(
          JointGeometry(joint.parent_from_joint, joint.child_from_joint, joint.axis),
          !ModelOf(joint.type).Parameters()[0].angle, JointValueFunction::BranchCentre(joint));
      const std::vector<int> blocks = {g.components[joint.parent].block,
                                       g.components[joint.child].block};
      double q = 0;
      EvaluateResidualAt(value, g.blocks, blocks, start, nullptr, &q, nullptr);
      x.q[j] = std::isfinite(q) ? q : 0.0;
    } else {
      x.motion[j] = ModelOf(joint.type).Nearest(joint.axis, M);
    }
  }
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k >= 0 && HasJointVariable(g.joints[j].type))
      x.q[j] = std::clamp(x.q[j], f.lower[k], f.upper[k]);
  }
  return x;
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
  const Placement place = Place(g, f, x);
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

// The components' poses at x, and G = d(their tangent coordinates)/d(parameters): parameter i
// turns component c, in its chart, by R_cᵀ ω_i and moves its origin by ω_i × t_c + v_i.
Values PosesAt(const ConstraintGraph& graph, const Forest& f,
               const std::vector<std::vector<Influence>>& influence, const Configuration& x,
               Eigen::MatrixXd* G) {
  const Placement place = Place(graph, f, x);
  Values values = graph.nominal;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    values.poses[graph.blocks[graph.components[c].block].index] = place.world_from_component[c];
  }
  MatchSlacks(graph, &values);
  const Eigen::MatrixXd T = Twists(graph, f, place, x);
  G->setZero(graph.tangent_dim(), f.size);
  for (size_t c = 0; c < graph.components.size(); ++c) {
    const Rigid3d& pose = place.world_from_component[c];
    const int offset = graph.blocks[graph.components[c].block].tangent_offset;
    const Eigen::Matrix3d Rt = pose.RotationMatrix().transpose();
    for (const Influence& in : influence[c]) {
      const auto t = T.col(in.twist);
      G->block<3, 1>(offset, in.parameter) += in.multiplier * (Rt * t.head<3>());
      G->block<3, 1>(offset + 3, in.parameter) +=
          in.multiplier * (t.head<3>().cross(pose.translation) + t.tail<3>());
    }
  }
  return values;
}

// The forest and its layout, or an InputError at the model.
Forest Prepare(const ConstraintGraph& graph, const ParametricOptions& options, double extent) {
  Forest f;
  if (const std::string why = Unsupported(graph, &f); !why.empty()) {
    throw InputError(SourceLocation(graph.source),
                     fmt::format("no parametric form for model '{}': {}", graph.name, why));
  }
  Layout(graph, options, extent, &f);
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
