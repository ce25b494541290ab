#include "cli/frame_results.h"

#include <algorithm>
#include <cmath>

#include "cfuse/interp/joint_estimates.h"
#include "cfuse/kernel/chi_square.h"
#include "cli/results.h"

namespace cfuse::cli {
namespace {

nlohmann::json OutlineJson(const Verification& v) {
  return {{"samples", v.samples},
          {"supported", v.supported},
          {"share", v.share},
          {"chance", v.chance},
          {"dominant_share", v.dominant_share},
          {"explained", ExplainedEvidence(v)}};
}

}  // namespace

nlohmann::json FrameJson(const ConstraintGraph& graph, const TrackedFrame& f) {
  nlohmann::json j = PosesJson(graph, f.estimate.mean);
  // Each rigid component's covariance (its tangent block: rotation, then translation, in the
  // camera frame) and each joint's value with its standard deviation.
  const Eigen::MatrixXd& p = f.estimate.covariance;
  j["covariance"] = nlohmann::json::object();
  for (const Component& c : graph.components) {
    if (!c.rigid || c.block >= static_cast<int>(f.estimate.blocks.size())) continue;
    const int o = f.estimate.blocks[c.block].tangent_offset;
    if (p.rows() < o + 6) continue;
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 6; ++r) {
      nlohmann::json row = nlohmann::json::array();
      for (int k = 0; k < 6; ++k) row.push_back(p(o + r, o + k));
      rows.push_back(row);
    }
    j["covariance"][c.name] = rows;
  }
  j["joints"] = nlohmann::json::object();
  if (p.size() > 0) {
    const JointEstimates joints = EstimateJoints(graph, f.estimate);
    for (size_t k = 0; k < joints.joints.size(); ++k) {
      j["joints"][graph.joints[joints.joints[k]].name] = {
          {"value", joints.values[static_cast<int>(k)]},
          {"sigma", std::sqrt(std::max(0.0, joints.covariance(k, k)))}};
    }
  }
  j["verified"] = f.verified;
  j["matches"] = f.matches;
  // A lost frame has no accepted matches, and so no fit to test.
  const double p_value = f.fit_dof > 0 ? 1 - ChiSquareCdf(f.chi2, f.fit_dof) : 1.0;
  j["fit"] = {{"chi2", f.chi2},
              {"dof", f.fit_dof},
              {"p_value", f.verified ? nlohmann::json(p_value) : nlohmann::json()},
              {"residual_px", f.residual_sigma}};
  j["position_sigma_m"] = f.position_sigma;
  j["outline"] = OutlineJson(f.verification);
  if (!f.verified) j["refused"] = f.verification.why;
  return j;
}


nlohmann::json DetectionJson(const ConstraintGraph& graph, const Detection& d,
                             const std::string& image) {
  nlohmann::json json = {{"model", graph.name}, {"image", image},
                         {"found", !d.found.empty()}, {"objects", nlohmann::json::array()}};
  for (size_t i = 0; i < d.found.size(); ++i) {
    nlohmann::json object = FrameJson(graph, d.found[i]);
    object["same_outline_elsewhere"] = nlohmann::json::array();
    for (const Values& twin : d.twins[i]) {
      object["same_outline_elsewhere"].push_back(PosesJson(graph, twin)["components"]);
    }
    json["objects"].push_back(object);
  }
  if (!d.why.empty()) json["why"] = d.why;
  // The best candidates refused, for a user asking why nothing (or nothing else) was found.
  json["refused"] = nlohmann::json::array();
  for (const DetectionCandidate& c : d.candidates) {
    if (json["refused"].size() >= 5) break;
    if (!c.frame.verified) json["refused"].push_back(FrameJson(graph, c.frame));
  }
  const DetectionStats& s = d.stats;
  json["stats"] = {{"segments", s.segments},         {"junctions", s.junctions},
                   {"vertices", s.vertices},         {"poses_ranked", s.poses},
                   {"candidates_tracked", s.candidates},
                   {"junctions_cut", s.junctions_cut}, {"poses_cut", s.poses_cut},
                   {"ms", {{"segments", s.segment_ms},
                           {"orientations", s.orientation_ms},
                           {"ranking", s.ranking_ms},
                           {"tracking", s.tracking_ms},
                           {"total", s.Total()}}}};
  return json;
}

}  // namespace cfuse::cli
