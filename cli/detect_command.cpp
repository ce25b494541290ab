#include "cli/detect_command.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>
#include <cmath>
#include <ostream>

#include "cfuse/geometry/model_edges.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/track/detector.h"
#include "cli/command_support.h"
#include "cli/image_support.h"
#include "cli/results.h"
#include "cli/track_overlay.h"

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
  j["fit"] = {{"chi2", f.chi2}, {"dof", f.fit_dof}, {"residual_px", f.residual_sigma}};
  j["position_sigma_m"] = f.position_sigma;
  j["outline"] = OutlineJson(f.verification);
  if (!f.verified) j["refused"] = f.verification.why;
  return j;
}

}  // namespace

int RunDetect(const DetectCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    for (const std::string* path : {&options.output, &options.overlay}) {
      if (!path->empty()) RequireWritable(*path);
    }
    if (options.max_results < 1) {
      throw InputError(SourceLocation("--max-results"), "must be at least 1");
    }
    const ConstraintGraph graph = LoadAnyModel(options.model);
    if (ModelEdges(graph).empty()) {
      throw InputError(SourceLocation(options.model),
                       fmt::format("model '{}' has no edges to find in an image (give its "
                                   "components edges, or faces whose sides become edges)",
                                   graph.name));
    }
    Camera camera = LoadAnyCamera(options.camera);
    const cv::Mat image = ReadGrayImage(options.image);
    if (camera.width <= 0 || camera.height <= 0) {
      SizeCameraFromImage(image, options.image, options.camera, &camera);
    } else if (image.cols != camera.width || image.rows != camera.height) {
      throw InputError(SourceLocation(options.image),
                       fmt::format("the image is {} x {}, the camera's ({}) {} x {}", image.cols,
                                   image.rows, options.camera, camera.width, camera.height));
    }
    const GrayView view{image.data, image.cols, image.rows, static_cast<int>(image.step)};
    DetectorOptions detector;
    detector.max_results = options.max_results;
    const Detection d = Detect(graph, camera, view, detector);

    nlohmann::json json = {{"model", graph.name}, {"image", options.image},
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
    const std::string text = json.dump(2) + "\n";
    if (!options.overlay.empty()) {
      // The object found, or the best candidate tracked, marked as refused.
      const TrackedFrame shown = !d.found.empty()      ? d.found[0]
                                 : d.candidates.empty() ? TrackedFrame{}
                                                        : d.candidates[0].frame;
      OverlayOptions overlay;
      overlay.caption = d.found.empty()
                            ? fmt::format("NOT FOUND  {:.0f} ms", s.Total())
                            : fmt::format("found  {} matches  {:.0f} ms", shown.matches, s.Total());
      WriteFileAtomically(options.overlay,
                          PngBytes(DrawOverlay(view, graph, camera, shown, overlay)));
    }
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    if (s.junctions_cut || s.poses_cut) {
      err << fmt::format("cfuse detect: the search was cut short ({})\n",
                         s.poses_cut ? "the bound on ranked poses was reached"
                                     : "junctions beyond the strongest were left out");
    }
    if (d.found.empty()) {
      err << fmt::format("cfuse detect: {} not found in {}: {}\n", graph.name, options.image, d.why);
      return 1;
    }
    for (size_t i = 0; i < d.found.size(); ++i) {
      const Verification& v = d.found[i].verification;
      err << fmt::format(
          "cfuse detect: {} found ({} of {}): {} matched edges, {:.0f} % of the outline supported "
          "(chance {:.0f} %), {:.1f} px RMS{}\n",
          graph.name, i + 1, d.found.size(), d.found[i].matches, 100 * v.share, 100 * v.chance,
          d.found[i].residual_sigma,
          d.twins[i].empty()
              ? ""
              : fmt::format("; the same outline at {} other pose(s): the model's symmetry, "
                            "which the image cannot tell apart",
                            d.twins[i].size()));
    }
    return 0;
  });
}

}  // namespace cfuse::cli
