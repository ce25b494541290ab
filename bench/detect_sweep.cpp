// Detection with no pose given (cfuse/track/detector.h) on realistic renders at random poses:
// the rigid box, ViSP's castle and the hinged box, each at `--trials` poses (the hinged box's lid
// at a random angle within its limits), seen from above at 10-70 degrees of elevation, any
// azimuth, turned up to 30 degrees about the line of sight, 100-320 px across, anywhere in the
// middle 60 % of the image; every third with a dark occluder over a quarter of it. Each render is
// textured with the photographs of Debian's visp-images-data (procedural cards without it).
//
// "Right": every point of the model found within 3 px on average of the nearest point of the
// truth (so a box turned half round, which draws the same outline, is right); "wrong": found and
// further off; "not found": refused, with the reason.
//
//   build/bench/detect_sweep --trials 200 [--models box,castle,hinged-box] [--verbose]
//                            [--seed 1] [--arm-trace-gap 12]
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>

#include "bench/chamfer_baseline.h"
#include "bench/sweep_main.h"
#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/cao.h"
#include "cfuse/track/detector.h"
#include "cfuse/vision/render.h"
#include "cfuse/vision/texture.h"

namespace cfuse::bench {
namespace {

struct Case {
  std::string name;
  ConstraintGraph graph;
  Camera camera;
};

Camera Pinhole(double f) {
  Camera c;
  c.fx = c.fy = f;
  c.cx = 320;
  c.cy = 240;
  c.width = 640;
  c.height = 480;
  return c;
}

// The mean distance (px) from each point `found` projects to the nearest the truth projects.
double MeanDistance(const ConstraintGraph& graph, const Camera& camera, const Values& found,
                    const Values& truth) {
  const std::vector<Eigen::Vector2d> a = ProjectedPoints(graph, camera, found);
  const std::vector<Eigen::Vector2d> b = ProjectedPoints(graph, camera, truth);
  double sum = 0;
  for (const Eigen::Vector2d& p : a) {
    double nearest = INFINITY;
    for (const Eigen::Vector2d& q : b) nearest = std::min(nearest, (p - q).norm());
    sum += nearest;
  }
  return sum / static_cast<double>(std::max<size_t>(1, a.size()));
}

// A random configuration in view (the file's comment).
Values RandomPose(const Case& c, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  std::map<std::string, double> joints;
  for (const Joint& j : c.graph.joints) {
    if (HasJointVariable(j.type) && !j.mimic && j.limits) {
      joints[j.name] = j.limits->first + unit(rng) * (j.limits->second - j.limits->first);
    }
  }
  const Values model = c.graph.joints.empty()
                           ? c.graph.nominal
                           : ForwardKinematics(c.graph, CompleteJointValues(c.graph, {}));
  Values posed = model;
  if (!joints.empty()) {
    std::vector<JointValue> given;
    for (const auto& [name, q] : joints) given.push_back({name, q, {}});
    posed = ForwardKinematics(c.graph, CompleteJointValues(c.graph, given));
  }
  // The object's centre and size.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (const Component& comp : c.graph.components) {
    if (!comp.rigid) continue;
    const Rigid3d& pose = posed.poses[c.graph.blocks[comp.block].index];
    for (const FeaturePoint& p : comp.points) {
      lo = lo.cwiseMin(pose * p.position);
      hi = hi.cwiseMax(pose * p.position);
    }
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double size = (hi - lo).norm();
  // The camera on a sphere about the centre, z of the object up.
  const double azimuth = 2 * M_PI * unit(rng);
  const double elevation = (10 + 60 * unit(rng)) * M_PI / 180;
  const double roll = (unit(rng) - 0.5) * 60 * M_PI / 180;
  const double pixels = 100 + 220 * unit(rng);
  const double distance = c.camera.fx * size / pixels;
  const Eigen::Vector3d eye =
      centre + distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                          std::cos(elevation) * std::sin(azimuth),
                                          std::sin(elevation));
  const Eigen::Vector3d forward = (centre - eye).normalized();
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d world_from_camera;
  world_from_camera << right, down, forward;
  const Eigen::Matrix3d turned =
      world_from_camera * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  // Moved across the view: the centre anywhere in the middle 60 % of the image.
  const double u = (0.2 + 0.6 * unit(rng)) * c.camera.width, v = (0.2 + 0.6 * unit(rng)) * c.camera.height;
  const Eigen::Vector3d shift((u - c.camera.cx) / c.camera.fx * distance,
                              (v - c.camera.cy) / c.camera.fy * distance, 0);
  const Rigid3d camera_from_world =
      Rigid3d(Eigen::Matrix3d(turned.transpose()), -(turned.transpose() * eye)) ;
  const Rigid3d moved(Eigen::Quaterniond::Identity(), -shift);
  Values out = posed;
  const Rigid3d camera_from_model = moved.Inverse() * camera_from_world;
  for (Rigid3d& pose : out.poses) pose = camera_from_model * pose;
  for (Eigen::Vector3d& p : out.points) p = camera_from_model * p;
  return out;
}

int Run(int argc, char** argv) {
  CLI::App app{"cfuse detect on realistic renders at random poses"};
  int trials = 200;
  std::string names = "box,castle,hinged-box";
  bool verbose = false;
  unsigned seed = 1;
  app.add_option("--trials", trials);
  app.add_option("--models", names, "box, castle, hinged-box");
  app.add_option("--seed", seed);
  app.add_flag("--verbose", verbose, "a line per trial");
  std::string detector_name = "lowe";
  app.add_option("--segments", detector_name, "the segment detector: lowe, canny, lsd or hough");
  int hough_votes = 30, hough_gap = 12;
  double junction_gap = 6;
  double arm_trace_gap = DetectorOptions().arm_trace_gap;
  bool oracle = false;
  app.add_flag("--oracle", oracle,
               "also track each render from its true pose: the share the tracker's verification "
               "passes, detection's ceiling");
  app.add_option("--junction-gap", junction_gap, "px from a crossing to the segments' ends");
  app.add_option(
      "--arm-trace-gap", arm_trace_gap,
      "px of an arm's line without a step where its traced end stops (0: the segment's end)");
  app.add_option("--hough-votes", hough_votes);
  app.add_option("--hough-gap", hough_gap, "px bridged along a line");
  bool candidates = false;
  app.add_flag("--candidates", candidates, "with --verbose: each candidate tracked, and how far off");
  bool chamfer = false;
  app.add_flag("--chamfer", chamfer,
               "the baseline instead of cfuse's hypotheses: chamfer matching over a pose grid, "
               "the best poses tracked and decided among by the detector (bench/chamfer_baseline.h"
               "; a model's joints at their nominal values)");
  std::string dump;
  app.add_option("--dump", dump,
                 "a directory for each render and its features (segments green, junctions red, "
                 "the truth's points blue)");
  CLI11_PARSE(app, argc, argv);
  const std::string castle =
      "/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu/Models/chateau.cao";
  auto photographs =
      std::make_shared<const std::vector<GrayImage>>(LoadPhotographs(VispPhotographPaths()));
  fmt::print("| model | trials | found right | found wrong | not found | ms a frame, median | "
             "split (segments and junctions, orientations, ranking, tracking) |\n"
             "|---|---|---|---|---|---|---|\n");
  std::stringstream list(names);
  for (std::string name; std::getline(list, name, ',');) {
    Case c;
    c.name = name;
    if (name == "box") {
      c.graph = ImportCao(std::string(CFUSE_SOURCE_DIR) + "/tests/data/cao/file_box.cao");
      c.camera = Pinhole(800);
    } else if (name == "castle") {
      c.graph = ImportCao(castle);
      c.camera = Pinhole(700);
    } else if (name == "hinged-box") {
      c.graph = LoadModel(std::string(CFUSE_SOURCE_DIR) + "/examples/hinged-box.yaml");
      c.camera = Pinhole(800);
    } else {
      throw std::invalid_argument("unknown model '" + name + "'");
    }
    std::optional<ChamferBaseline> baseline;
    if (chamfer) baseline.emplace(c.graph, c.camera);
    std::mt19937 rng(seed);
    int right = 0, wrong = 0, missed = 0, oracle_verified = 0, oracle_plain = 0;
    std::vector<double> ms;
    DetectionStats sum;
    for (int t = 0; t < trials; ++t) {
      const Values truth = RandomPose(c, rng);
      RenderOptions render;
      render.style = RenderStyle::kRealistic;
      render.seed = seed * 1000 + t;
      render.realistic.photographs = photographs;
      render.realistic.look_seed = seed * 1000 + t;
      if (t % 3 == 2) {
        // A dark card over a quarter of the object's box in the image.
        Eigen::AlignedBox2d box;
        for (const Eigen::Vector2d& p : ProjectedPoints(c.graph, c.camera, truth)) box.extend(p);
        const Eigen::Vector2d size = box.sizes();
        std::uniform_real_distribution<double> unit(0, 1);
        const Eigen::Vector2d corner = box.min() + Eigen::Vector2d(unit(rng) * 0.5 * size.x(),
                                                                   unit(rng) * 0.5 * size.y());
        render.occluders.push_back({corner, corner + Eigen::Vector2d(0.5 * size.x(), 0),
                                    corner + 0.5 * size, corner + Eigen::Vector2d(0, 0.5 * size.y())});
      }
      const Rendering r = Render(c.graph, truth, c.camera, render);
      if (!dump.empty()) {
        const std::vector<std::uint8_t> png = EncodePng(r.pixels, r.width, r.height);
        std::ofstream(fmt::format("{}/{}_{}.png", dump, name, t), std::ios::binary)
            .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
      }
      const GrayView view{r.pixels.data(), r.width, r.height, r.width};
      const auto start = std::chrono::steady_clock::now();
      DetectorOptions options;
      options.junctions.max_gap = junction_gap;
      options.arm_trace_gap = arm_trace_gap;
      if (oracle) {
        TrackerOptions quick;
        quick.settle_places = quick.settle_depths = quick.settle_joint_values = 0;
        quick.settle_tilts = 0;
        Tracker tracker(c.graph, c.camera, truth, quick);
        const TrackedFrame f = tracker.Track(view);
        oracle_verified += f.verified;
        if (verbose) {
          fmt::print("  from the truth: {} {}, share {:.2f} chance {:.2f} dominant {:.2f}, {} matches\n",
                     f.verified ? "verified" : "refused", f.verification.why, f.verification.share,
                     f.verification.chance, f.verification.dominant_share, f.matches);
        }
        oracle_plain += f.verified && f.matches >= options.min_matches &&
                        f.verification.share - f.verification.chance >= options.min_margin &&
                        f.verification.dominant_share >= options.min_dominant;
      }
      std::vector<ImageSegment> lines;
      if (detector_name == "hough") {
        // Canny's edges, and OpenCV's probabilistic Hough transform bridging gaps along a line.
        cv::Mat grey(r.height, r.width, CV_8U, const_cast<std::uint8_t*>(r.pixels.data())), edges;
        cv::GaussianBlur(grey, edges, cv::Size(0, 0), 1.2);
        cv::Canny(edges, edges, 20, 50);
        std::vector<cv::Vec4i> found;
        cv::HoughLinesP(edges, found, 1, M_PI / 360, hough_votes, 20, hough_gap);
        for (const cv::Vec4i& l : found) {
          ImageSegment g;
          g.a = Eigen::Vector2f(l[0], l[1]);
          g.b = Eigen::Vector2f(l[2], l[3]);
          g.strength = 30;
          lines.push_back(g);
        }
      } else {
        options.segments.detector = *ParseDetector(detector_name);
      }
      Detection d;
      if (baseline) {
        // The split: Canny and its distance transforms, the grid's matching, its refinement.
        ChamferStats stats;
        d = DetectFrom(c.graph, c.camera, view, baseline->Candidates(view, &stats), options);
        d.stats.segment_ms = stats.edges_ms;
        d.stats.orientation_ms = stats.matching_ms;
        d.stats.ranking_ms = stats.refinement_ms;
      } else {
        d = Detect(c.graph, c.camera, view, options, detector_name == "hough" ? &lines : nullptr);
      }
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                       .count());
      sum.segment_ms += d.stats.segment_ms;
      sum.orientation_ms += d.stats.orientation_ms;
      sum.ranking_ms += d.stats.ranking_ms;
      sum.tracking_ms += d.stats.tracking_ms;
      double px = NAN;
      if (d.found.empty()) {
        ++missed;
      } else {
        px = MeanDistance(c.graph, c.camera, d.found[0].estimate.mean, truth);
        (px <= 3 ? right : wrong) += 1;
      }
      if (!dump.empty()) {
        cv::Mat3b canvas;
        cv::cvtColor(cv::Mat(r.height, r.width, CV_8U, const_cast<std::uint8_t*>(r.pixels.data())),
                     canvas, cv::COLOR_GRAY2BGR);
        for (const ImageSegment& g : d.segments) {
          cv::line(canvas, cv::Point2f(g.a.x(), g.a.y()), cv::Point2f(g.b.x(), g.b.y()),
                   cv::Scalar(0, 200, 0), 1);
        }
        for (const Junction& j : d.junctions) {
          cv::circle(canvas, cv::Point2d(j.corner.x(), j.corner.y()), 3, cv::Scalar(0, 0, 255), 1);
        }
        for (const Eigen::Vector2d& p : ProjectedPoints(c.graph, c.camera, truth)) {
          cv::drawMarker(canvas, cv::Point2d(p.x(), p.y()), cv::Scalar(255, 0, 0), cv::MARKER_CROSS, 8);
        }
        cv::imwrite(fmt::format("{}/{}_{}_features.png", dump, name, t), canvas);
      }
      if (verbose) {
        if (!d.found.empty()) {
          const Verification& v = d.found[0].verification;
          fmt::print("  found: share {:.2f}, chance {:.2f}, dominant {:.2f}, agreement {:.2f}, "
                     "spread {:.2f}, samples {}, matches {}\n",
                     v.share, v.chance, v.dominant_share, v.agreement, v.spread, v.samples,
                     d.found[0].matches);
        }
        fmt::print("{} trial {}{}: {} ({:.1f} px), {:.0f} ms{}{}\n", name, t,
                   t % 3 == 2 ? " (occluded)" : "",
                   d.found.empty() ? "not found" : (px <= 3 ? "right" : "WRONG"), px, ms.back(),
                   d.why.empty() ? "" : ": ", d.why);
        if (candidates) {
          for (const DetectionCandidate& k : d.candidates) {
            fmt::print("   candidate vertex {} evidence {:.0f}: start {:.1f} px, tracked {:.1f} px "
                       "{}: {}\n",
                       k.vertex, k.evidence, MeanDistance(c.graph, c.camera, k.values, truth),
                       MeanDistance(c.graph, c.camera, k.frame.estimate.mean, truth),
                       k.frame.verified ? "verified" : "refused", k.frame.verification.why);
          }
        }
      }
    }
    std::sort(ms.begin(), ms.end());
    const double n = trials;
    fmt::print("| {} | {} | {} ({:.0f} %) | {} | {} | {:.1f} | {:.1f}, {:.1f}, {:.1f}, {:.1f} |\n",
               chamfer ? name + " (chamfer baseline)" : name, trials, right, 100.0 * right / n,
               wrong, missed, ms[ms.size() / 2], sum.segment_ms / n, sum.orientation_ms / n,
               sum.ranking_ms / n, sum.tracking_ms / n);
    if (oracle) {
      fmt::print("  from the true pose: {} of {} verified, {} plain enough for detection\n",
                 oracle_verified, trials, oracle_plain);
    }
  }
  return 0;
}

}  // namespace
}  // namespace cfuse::bench

int main(int argc, char** argv) {
  return cfuse::bench::SweepMain("detect_sweep", cfuse::bench::Run, argc, argv);
}
