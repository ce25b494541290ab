#include "cli/results.h"

#include <algorithm>
#include <cmath>

#include "cfuse/interp/joint_estimates.h"

namespace cfuse::cli {
namespace {

nlohmann::json Matrix(const Eigen::MatrixXd& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int i = 0; i < m.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json Vector(const Eigen::VectorXd& v) {
  nlohmann::json out = nlohmann::json::array();
  for (int i = 0; i < v.size(); ++i) out.push_back(v[i]);
  return out;
}

// The covariance of frame F = C T (T = component_from_frame) from that of its component C, in
// the results' tangent coordinates [δθ in the frame's axes; δt in the viewer frame]:
// R_C Exp(δθ) R_T = R_C R_T Exp(R_Tᵀ δθ), and t_F moves by δt - R_C [t_T]× δθ.
Eigen::Matrix<double, 6, 6> FrameCovariance(const Rigid3d& world_from_component,
                                            const Rigid3d& component_from_frame,
                                            const Eigen::MatrixXd& component_covariance) {
  const Eigen::Matrix3d R_T = component_from_frame.RotationMatrix();
  const Eigen::Vector3d t = component_from_frame.translation;
  Eigen::Matrix3d t_cross;
  t_cross << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Zero();
  J.topLeftCorner<3, 3>() = R_T.transpose();
  J.bottomLeftCorner<3, 3>() = -world_from_component.RotationMatrix() * t_cross;
  J.bottomRightCorner<3, 3>().setIdentity();
  return J * component_covariance * J.transpose();
}

std::string LabelOf(const ConstraintGraph& graph, const ResolvedLabel& r) {
  const Component& c = graph.components[r.component];
  return r.feature < 0 ? c.name : c.name + "." + c.points[r.feature].name;
}

}  // namespace

nlohmann::json SolutionJson(const ConstraintGraph& graph, const MeasurementSet& set,
                            const Solution& solution, double time_ms) {
  const GaussianState& s = solution.state;
  nlohmann::json out;
  out["components"] = nlohmann::json::object();
  out["points"] = nlohmann::json::object();
  for (const Component& c : graph.components) {
    const Block& b = graph.blocks[c.block];
    const Eigen::MatrixXd cov = s.covariance.block(b.tangent_offset, b.tangent_offset,
                                                   TangentDim(b.kind), TangentDim(b.kind));
    if (c.rigid) {
      const Rigid3d& pose = s.mean.poses[b.index];
      const Eigen::Quaterniond q = pose.rotation.normalized();
      out["components"][c.name] = {{"position", Vector(pose.translation)},
                                   {"quaternion", {q.w(), q.x(), q.y(), q.z()}},
                                   {"covariance", Matrix(cov)}};
      for (const ComponentFrame& f : c.frames) {
        const Rigid3d frame = pose * f.component_from_frame;
        const Eigen::Quaterniond fq = frame.rotation.normalized();
        out["components"][f.name] = {
            {"position", Vector(frame.translation)},
            {"quaternion", {fq.w(), fq.x(), fq.y(), fq.z()}},
            {"covariance", Matrix(FrameCovariance(pose, f.component_from_frame, cov))}};
      }
    } else {
      out["points"][c.name] = {{"xyz", Vector(s.mean.points[b.index])}, {"cov", Matrix(cov)}};
    }
  }
  out["joints"] = nlohmann::json::object();
  const JointEstimates joints = EstimateJoints(graph, s);
  for (size_t i = 0; i < joints.joints.size(); ++i) {
    const int k = static_cast<int>(i);
    out["joints"][graph.joints[joints.joints[i]].name] = {
        {"value", joints.values[k]}, {"sigma", std::sqrt(std::max(0.0, joints.covariance(k, k)))}};
  }
  out["matches"] = nlohmann::json::array();
  std::vector<std::string> labels(set.points.size());
  for (const ResolvedLabel& r : solution.labels) labels[r.measurement] = LabelOf(graph, r);
  for (const std::string& l : labels)
    out["matches"].push_back(l.empty() ? nlohmann::json() : nlohmann::json(l));
  out["constraints"] = {{"count", graph.constraints.size()},
                        {"max_abs_residual", solution.summary.max_constraint_residual}};
  const Fit& fit = solution.analysis.fit;
  out["fit"] = {{"chi2", fit.chi2},
                {"dof", fit.dof},
                {"p_value", fit.p_value},
                {"residuals", fit.residuals}};
  out["undetermined"] = solution.undetermined;
  out["alternatives"] = nlohmann::json::array();
  for (const Solution::Alternative& a : solution.alternatives) {
    nlohmann::json alternative = PosesJson(graph, a.mean);
    alternative["fit"] = {{"chi2", a.fit.chi2}, {"dof", a.fit.dof}, {"p_value", a.fit.p_value}};
    alternative["joints"] = nlohmann::json::object();
    const Eigen::VectorXd q = JointValues(graph, a.mean);
    int k = 0;
    for (const Joint& j : graph.joints) {
      if (HasJointVariable(j.type)) alternative["joints"][j.name] = {{"value", q[k++]}};
    }
    out["alternatives"].push_back(alternative);
  }
  out["valleys"] = nlohmann::json::array();
  for (const Solution::Valley& v : solution.valleys) {
    out["valleys"].push_back({{"component", v.component},
                              {"tilt_towards_mirror_rad", v.towards_mirror},
                              {"tilt_away_rad", v.away}});
  }
  out["status"] = {{"converged", solution.summary.converged && solution.fits},
                   {"constraints_hold", solution.summary.converged},
                   {"fits", solution.fits},
                   {"passes", solution.summary.passes},
                   {"contradictions", solution.contradictions},
                   {"invalid", solution.invalid}};
  if (!solution.rejected.empty()) {
    nlohmann::json rejected = nlohmann::json::array();
    for (const Solution::Rejection& r : solution.rejected) {
      rejected.push_back({{"measurement", r.measurement},
                          {"label", set.points[r.measurement].label},
                          {"sigmas", r.sigmas}});
    }
    out["status"]["rejected"] = rejected;
  }
  out["time_ms"] = time_ms;
  return out;
}

nlohmann::json MeasurementsJson(const MeasurementSet& set) {
  nlohmann::json out;
  if (set.camera) {
    const Camera& c = *set.camera;
    if (c.model == Camera::Model::kPinhole) {
      out["camera"] = {
          {"fx", c.fx},
          {"fy", c.fy},
          {"cx", c.cx},
          {"cy", c.cy},
          {"width", c.width},
          {"height", c.height},
          {"dist", std::vector<double>(c.distortion.begin(), c.distortion.begin() + 5)}};
      const bool more = std::any_of(c.distortion.begin() + 5, c.distortion.end(),
                                    [](double d) { return d != 0; });
      if (more)
        out["camera"]["dist"] = std::vector<double>(c.distortion.begin(), c.distortion.end());
    } else {
      out["camera"] = {{"model", "orthographic"}, {"scale", c.scale},  {"cx", c.cx}, {"cy", c.cy},
                       {"width", c.width},        {"height", c.height}};
    }
  }
  out["points"] = nlohmann::json::array();
  for (const MeasuredPoint& m : set.points) {
    nlohmann::json p;
    if (m.is_3d) {
      p["xyz"] = Vector(m.xyz);
      p["cov"] = Matrix(m.cov3);
    } else {
      p["uv"] = Vector(m.uv);
      p["cov"] = Matrix(m.cov2);
    }
    if (!m.label.empty()) p["label"] = m.label;
    out["points"].push_back(p);
  }
  return out;
}

nlohmann::json PosesJson(const ConstraintGraph& graph, const Values& values) {
  nlohmann::json out;
  out["components"] = nlohmann::json::object();
  out["points"] = nlohmann::json::object();
  auto pose_json = [](const Rigid3d& pose) {
    const Eigen::Quaterniond q = pose.rotation.normalized();
    return nlohmann::json{{"position", Vector(pose.translation)},
                          {"quaternion", {q.w(), q.x(), q.y(), q.z()}}};
  };
  for (const Component& c : graph.components) {
    const Block& b = graph.blocks[c.block];
    if (c.rigid) {
      const Rigid3d& pose = values.poses[b.index];
      out["components"][c.name] = pose_json(pose);
      for (const ComponentFrame& f : c.frames) {
        out["components"][f.name] = pose_json(pose * f.component_from_frame);
      }
    } else {
      out["points"][c.name] = {{"xyz", Vector(values.points[b.index])}};
    }
  }
  return out;
}

nlohmann::json TruthJson(const ConstraintGraph& graph, const Values& truth,
                         const std::vector<std::string>& matches) {
  nlohmann::json out = PosesJson(graph, truth);
  out["joints"] = nlohmann::json::object();
  const Eigen::VectorXd q = JointValues(graph, truth);
  int k = 0;
  for (const Joint& j : graph.joints) {
    if (HasJointVariable(j.type)) out["joints"][j.name] = {{"value", q[k++]}};
  }
  out["matches"] = nlohmann::json::array();
  for (const std::string& m : matches)
    out["matches"].push_back(m.empty() ? nlohmann::json() : nlohmann::json(m));
  return out;
}

}  // namespace cfuse::cli
