// Tracking on ViSP's data (docs/benchmarks.md, "Tracking on ViSP's data"): cfuse's tracker and
// ViSP's edge tracker (vpMbGenericTracker, bench/visp_tracker.h) on the public sequences of
// Debian's visp-images-data, each with ViSP's own model, camera, settings and initial pose, the
// same frames in the same run.
//
//   visp_sequences [--sequences castle-simu,castel] [--steps 1,2,3] [--repeat 3]
//                  [--perturb N] [--seed 1] [--csv DIR] [--support] [--visp-scanline]
//                  [--depth [--depth-stride PX] [--depth-points N] [--depth-effective N]]
//
// ViSP runs at its default visibility, without the scan-line test: on Castle-simu and castel
// the test makes it four times slower and no more accurate. --visp-scanline turns it on. The
// references without truth (castel's, the cube's) keep it on, as they were first measured.
// --support scores every track's poses alike by the share of the outline the image supports.
//
// Sequences (`cube` only when named: it is held back as an independent check):
//   castle-simu  mbt-depth/Castle-simu: 40 rendered frames, and their depth, with the true camera
//                pose of each; started from frame 1's true pose.
//   castel       mbt-depth/castel: 30 real frames of the castle filling the view, with depth; no
//                truth: the reference is ViSP's track with edges and dense depth together (its
//                own example's), and cfuse's distance from ViSP's edges-only track is shown too;
//                started from chateau.0.pos.
//   cube         mbt/cube: 218 real frames of a cube pushed by hand; no truth, as castel.
// For each sequence and frame step k (every k-th frame: k times the motion): frames verified
// (cfuse) or returned (ViSP), frames verified more than 10 mm from the reference ("wrong"),
// the median and worst position error of those frames, and the time per frame (the median over
// `repeat` runs of each tracker's mean), with cfuse's split by stage.
//
// With --depth, on a sequence with depth frames (castel): cfuse with the range sensor's points
// fused too (cfuse/track/depth_evidence.h), and ViSP with its edges and dense depth, in two more
// rows; the perturbed starts are then tracked with depth.
//
// With --perturb N: N trials per sequence, each a fresh tracker started at a random frame from
// the reference pose moved by 10 to 100 % of --perturb-mm (60) and turned by 10 to 100 % of
// --perturb-deg (20 degrees), tracking 5 frames: how
// many frames are verified, and how many of those are wrong (more than 10 mm from the
// reference, or 3 px mean edge distance). Verification must refuse every wrong one.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench/chamfer_baseline.h"
#include "bench/tracker_ablation.h"
#include "bench/visp_tracker.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/importers/cao.h"
#include "cfuse/track/auto_tracker.h"
#include "cfuse/track/detector.h"
#include "cfuse/track/tracker.h"
#include "cfuse/track/verification.h"
#include "cfuse/vision/depth_file.h"

namespace {

using namespace cfuse;
namespace fs = std::filesystem;

const std::string kData = "/usr/share/visp-images-data/ViSP-images/";

struct Sequence {
  std::string name, cao, images_format;
  int first = 0, count = 0;
  Camera camera;
  bench::VispOptions visp;
  std::vector<Rigid3d> truth;  // camera_from_object per frame, when known
  Rigid3d start;
  // Depth frames, for the reference track of a sequence without truth (ViSP's edges and dense
  // depth): the files, the depth camera's settings and its pose from the grey camera's.
  std::string depth_format, depth_config;
  Rigid3d depth_from_color;
  DepthIntrinsics depth_intrinsics;
  double depth_unit = 0.001;  // metres
};

Rigid3d FromThetaU(const std::vector<double>& v) {
  const Eigen::Vector3d w(v[3], v[4], v[5]);
  const double angle = w.norm();
  const Eigen::Quaterniond q = angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle))
                                         : Eigen::Quaterniond::Identity();
  return Rigid3d(q, Eigen::Vector3d(v[0], v[1], v[2]));
}

std::vector<double> Numbers(const std::string& path) {
  std::ifstream in(path);
  std::vector<double> v;
  double x;
  while (in >> x) v.push_back(x);
  return v;
}

Camera Pinhole(double px, double py, double u0, double v0) {
  Camera c;
  c.fx = px;
  c.fy = py;
  c.cx = u0;
  c.cy = v0;
  c.width = 640;
  c.height = 480;
  return c;
}

Sequence Load(const std::string& name) {
  Sequence s;
  s.name = name;
  if (name == "castle-simu") {
    const std::string d = kData + "mbt-depth/Castle-simu/";
    s.cao = d + "Models/chateau.cao";
    s.images_format = d + "Images/Image_{:04d}.pgm";
    s.first = 1;
    s.count = 40;
    s.camera = Pinhole(700, 700, 320, 240);  // Config/chateau.xml
    for (int k = 1; k <= s.count; ++k) {
      const std::vector<double> m = Numbers(d + fmt::format("CameraPose/Camera_{:03d}.txt", k));
      Eigen::Matrix3d r;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = m[4 * i + j];
      s.truth.push_back(
          Rigid3d(Eigen::Quaterniond(r).normalized(), Eigen::Vector3d(m[3], m[7], m[11])));
    }
    s.start = s.truth[0];
    s.visp.config_file = d + "Config/chateau.xml";
    s.visp.range = 8;
    s.visp.threshold = 10000;
    s.visp.sample_step = 5;
    s.visp.angle_appear_deg = 85;
    s.visp.angle_disappear_deg = 89;
    s.visp.near_clipping = 0.01;
    s.visp.far_clipping = 2;
    // Depth as ViSP's testGenericTrackerDepth.cpp reads it: its camera (Config/chateau_depth.xml)
    // 5 cm beside the grey one, its unit 0.000030518 m.
    s.depth_format = d + "Depth/Depth_{:04d}.bin";
    s.depth_config = d + "Config/chateau_depth.xml";
    s.depth_from_color = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.05, 0, 0));
    s.depth_intrinsics.fx = s.depth_intrinsics.fy = 700;
    s.depth_intrinsics.cx = 320;
    s.depth_intrinsics.cy = 240;
    s.depth_unit = 0.000030518;
  } else if (name == "castel") {
    const std::string d = kData + "mbt-depth/castel/";
    s.cao = d + "chateau.cao";
    s.images_format = d + "castel/image_{:04d}.pgm";
    s.first = 0;
    s.count = 30;
    s.camera = Pinhole(615.1674804688, 615.1675415039, 312.1889953613, 243.4373779297);
    s.start = FromThetaU(Numbers(d + "chateau.0.pos"));
    s.visp.config_file = d + "chateau.xml";
    s.depth_format = d + "castel/depth_image_{:04d}.bin";
    s.depth_config = d + "chateau_depth.xml";
    const std::vector<double> m = Numbers(d + "depth_M_color.txt");
    Eigen::Matrix3d r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = m[4 * i + j];
    s.depth_from_color =
        Rigid3d(Eigen::Quaterniond(r).normalized(), Eigen::Vector3d(m[3], m[7], m[11]));
    s.depth_intrinsics = CastelDepthIntrinsics();
    s.depth_unit = kCastelMetresPerUnit;
    s.visp.range = 8;
    s.visp.threshold = 10000;
    s.visp.sample_step = 5;
    s.visp.angle_appear_deg = 70;
    s.visp.angle_disappear_deg = 80;
    s.visp.near_clipping = 0.01;
    s.visp.far_clipping = 2;
  } else if (name == "cube") {
    const std::string d = kData + "mbt/";
    s.cao = d + "cube.cao";
    s.images_format = d + "cube/image{:04d}.pgm";
    s.first = 0;
    s.count = 218;
    s.camera = Pinhole(547.7367575, 542.0744058, 338.7036994, 234.5083345);
    s.start = FromThetaU(Numbers(d + "cube.0.pos"));
    s.visp.config_file = d + "cube.xml";
    s.visp.range = 7;
    s.visp.threshold = 5000;
    s.visp.sample_step = 4;
    s.visp.angle_appear_deg = 65;
    s.visp.angle_disappear_deg = 75;
    s.visp.near_clipping = 0.1;
    s.visp.far_clipping = 0.9;
  } else {
    throw std::runtime_error("unknown sequence " + name);
  }
  return s;
}

std::vector<cv::Mat> Frames(const Sequence& s) {
  std::vector<cv::Mat> out;
  for (int k = 0; k < s.count; ++k) {
    const std::string path = fmt::format(fmt::runtime(s.images_format), s.first + k);
    cv::Mat m = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (m.empty()) throw std::runtime_error("cannot read " + path);
    out.push_back(m);
  }
  return out;
}

Values Posed(const ConstraintGraph& graph, const Rigid3d& camera_from_object) {
  Values v = graph.nominal;
  for (Rigid3d& pose : v.poses) pose = camera_from_object * pose;
  return v;
}

// The mean distance (px) of the model's visible edges at `a` from the same edges' lines at `b`.
double EdgeDistance(const ConstraintGraph& graph, const std::vector<ModelEdge>& edges,
                    const Camera& camera, const Rigid3d& a, const Rigid3d& b) {
  const Visibility visible{0, 0, true};
  const Values va = Posed(graph, a), vb = Posed(graph, b);
  double sum = 0;
  int n = 0;
  for (const ProjectedEdge& e : VisibleEdges(graph, edges, va, camera, visible)) {
    const Component& c = graph.components[edges[e.edge].component];
    const Rigid3d& pa = va.poses[graph.blocks[c.block].index];
    const Rigid3d& pb = vb.poses[graph.blocks[c.block].index];
    const Eigen::Vector3d A = pa.Inverse() * e.A, B = pa.Inverse() * e.B;
    const Eigen::Vector2d qa = camera.Project<double>(pb * A), qb = camera.Project<double>(pb * B);
    const Eigen::Vector2d d = (qb - qa).normalized(), normal(-d.y(), d.x());
    for (double t = 0; t <= 1.0001; t += 0.1) {
      sum += std::abs(normal.dot(e.a + t * (e.b - e.a) - qa));
      ++n;
    }
  }
  return n > 0 ? sum / n : 0;
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::string Num(double x, int digits = 2) {
  return std::isnan(x) ? "-" : fmt::format("{:.{}f}", x, digits);
}

struct Run {
  std::vector<Verification> verification;
  std::vector<double> position_sigma;
  std::vector<int> depth_points;  // fused (cfuse with depth)
  std::vector<bool> accepted;
  std::vector<Rigid3d> poses;
  std::vector<double> ms;
  FrameTimes mean;
};

Run TrackCfuse(const ConstraintGraph& graph, const Sequence& s, const std::vector<cv::Mat>& frames,
               const std::vector<int>& picked, const Rigid3d& start, const AutoTrackerOptions& base,
               EdgeEvidence evidence = EdgeEvidence::kNormalSearch,
               const std::vector<DepthFrame>* depth = nullptr) {
  Run run;
  AutoTrackerOptions options = base;
  options.tracker.evidence = evidence;
  AutoTracker tracker(graph, s.camera, Posed(graph, start), options);
  for (int k : picked) {
    const cv::Mat& m = frames[k];
    const GrayView view{m.data, m.cols, m.rows, static_cast<int>(m.step)};
    const TrackedFrame f = depth ? tracker.Track(view, (*depth)[k]) : tracker.Track(view);
    run.accepted.push_back(f.verified);
    run.verification.push_back(f.verification);
    run.position_sigma.push_back(f.position_sigma);
    run.depth_points.push_back(f.depth_points);
    run.poses.push_back(f.estimate.mean.poses[0] * graph.nominal.poses[0].Inverse());
    run.ms.push_back(f.times.Total());
    run.mean.segments += f.times.segments / picked.size();
    run.mean.prediction += f.times.prediction / picked.size();
    run.mean.search += f.times.search / picked.size();
    run.mean.estimation += f.times.estimation / picked.size();
    run.mean.verification += f.times.verification / picked.size();
  }
  return run;
}

Run TrackVisp(const Sequence& s, const std::vector<cv::Mat>& frames, const std::vector<int>& picked,
              const Rigid3d& start) {
  std::vector<const std::uint8_t*> pixels;
  for (int k : picked) pixels.push_back(frames[k].data);
  Run run;
  for (const bench::PeerFrame& f :
       bench::TrackWithVisp(pixels, 640, 480, s.camera, s.cao, start, s.visp)) {
    run.accepted.push_back(f.ok);
    run.poses.push_back(f.camera_from_object);
    run.ms.push_back(f.ms);
  }
  return run;
}

Run TrackVispDepth(const Sequence& s, const std::vector<cv::Mat>& frames,
                   const std::vector<bench::DepthCloud>& clouds, const std::vector<int>& picked,
                   const Rigid3d& start) {
  std::vector<const std::uint8_t*> pixels;
  std::vector<bench::DepthCloud> picked_clouds;
  for (int k : picked) {
    pixels.push_back(frames[k].data);
    picked_clouds.push_back(clouds[k]);
  }
  Run run;
  for (const bench::PeerFrame& f :
       bench::TrackWithVispDepth(pixels, 640, 480, s.camera, s.cao, start, s.visp, picked_clouds,
                                 s.depth_config, s.depth_from_color)) {
    run.accepted.push_back(f.ok);
    run.poses.push_back(f.camera_from_object);
    run.ms.push_back(f.ms);
  }
  return run;
}

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? NAN : s / v.size();
}

}  // namespace

// The mean distance (px) from where `a` projects each model point to the nearest point `b`
// projects: 0 for a symmetric model's twin (a cube turned a quarter round), which draws the
// same outline and which no image can tell from the reference.
double PointSetDistance(const ConstraintGraph& graph, const Camera& camera, const Rigid3d& a,
                        const Rigid3d& b) {
  const std::vector<Eigen::Vector2d> pa = ProjectedPoints(graph, camera, Posed(graph, a));
  const std::vector<Eigen::Vector2d> pb = ProjectedPoints(graph, camera, Posed(graph, b));
  double sum = 0;
  for (const Eigen::Vector2d& q : pa) {
    double nearest = INFINITY;
    for (const Eigen::Vector2d& r : pb) nearest = std::min(nearest, (q - r).norm());
    sum += nearest;
  }
  return pa.empty() ? 0 : sum / static_cast<double>(pa.size());
}

// Detection with no pose given, frame by frame: found right (the model's points at most 3 px on
// average from the nearest of the reference's: a symmetric model's twin is right), found wrong,
// not found, and the time split.
void DetectFrames(const ConstraintGraph& graph, const std::vector<ModelEdge>& edges,
                  const Sequence& s, const std::vector<cv::Mat>& frames,
                  const std::vector<Rigid3d>& reference, const DetectorOptions& options,
                  bool verbose, bool show_candidates,
                  const bench::ChamferBaseline* baseline = nullptr) {
  int right = 0, wrong = 0, missed = 0;
  std::vector<double> ms, errors;
  DetectionStats sum;
  for (int i = 0; i < s.count; ++i) {
    const GrayView view{frames[i].data, frames[i].cols, frames[i].rows,
                        static_cast<int>(frames[i].step)};
    const auto start = std::chrono::steady_clock::now();
    Detection d;
    if (baseline) {
      // The baseline's split: Canny and its distance transforms, the grid's matching, its
      // refinement, tracking; "poses" counts the grid's placements.
      bench::ChamferStats stats;
      const std::vector<Values> poses = baseline->Candidates(view, &stats);
      d = DetectFrom(graph, s.camera, view, poses, options);
      d.stats.segment_ms = stats.edges_ms;
      d.stats.orientation_ms = stats.matching_ms;
      d.stats.ranking_ms = stats.refinement_ms;
      d.stats.poses = stats.placements;
    } else {
      d = Detect(graph, s.camera, view, options);
    }
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    sum.segment_ms += d.stats.segment_ms;
    sum.orientation_ms += d.stats.orientation_ms;
    sum.ranking_ms += d.stats.ranking_ms;
    sum.tracking_ms += d.stats.tracking_ms;
    sum.poses += d.stats.poses;
    sum.junctions += d.stats.junctions;
    double px = NAN, mm = NAN;
    if (d.found.empty()) {
      ++missed;
    } else {
      const Rigid3d pose = d.found[0].estimate.mean.poses[0] * graph.nominal.poses[0].Inverse();
      px = PointSetDistance(graph, s.camera, pose, reference[i]);
      // The model's centre (the mean of its points), which a symmetric twin shares.
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      int count = 0;
      for (const Component& c : graph.components) {
        if (!c.rigid) continue;
        const Rigid3d& nominal = graph.nominal.poses[graph.blocks[c.block].index];
        for (const FeaturePoint& p : c.points) {
          centre += nominal * p.position;
          ++count;
        }
      }
      centre /= std::max(1, count);
      mm = 1000 * (pose * centre - reference[i] * centre).norm();
      (px <= 3 ? right : wrong) += 1;
      errors.push_back(mm);
    }
    if (verbose) {
      // The best candidate's rank among those tracked that verified, for tuning the ranking.
      int first_verified = -1;
      for (size_t c = 0; c < d.candidates.size() && first_verified < 0; ++c) {
        if (d.candidates[c].frame.verified) first_verified = static_cast<int>(c);
      }
      fmt::print("{} frame {}: {} ({} px, {} mm), {} junctions, {} poses, {} candidates, first "
                 "verified {}, {:.1f} ms{}{}\n",
                 s.name, s.first + i, d.found.empty() ? "not found" : (px <= 3 ? "right" : "WRONG"),
                 Num(px), Num(mm), d.stats.junctions, d.stats.poses, d.stats.candidates,
                 first_verified, ms.back(), d.why.empty() ? "" : ": ", d.why);
      if (!d.found.empty()) {
        const Verification& v = d.found[0].verification;
        fmt::print("  found: share {:.2f} dominant {:.2f} agreement {:.2f} spread {:.2f} chance "
                   "{:.2f} explained {:.0f} samples {} least {:.2f}\n",
                   v.share, v.dominant_share, v.agreement, v.spread, v.chance,
                   ExplainedEvidence(v), v.samples, v.least_component);
      }
      if (show_candidates && baseline) {
        fmt::print("  the reference's chamfer evidence {:.1f}\n",
                   baseline->Evidence(view, Posed(graph, reference[i])));
      }
      if (show_candidates) {
        for (const DetectionCandidate& c : d.candidates) {
          const Rigid3d pose =
              c.frame.estimate.mean.poses[0] * graph.nominal.poses[0].Inverse();
          const double evidence = baseline ? baseline->Evidence(view, c.values) : c.evidence;
          fmt::print(
              "  candidate: component {} vertex {} evidence {:.1f}: {} {:.1f} px, "
              "explained {:.1f}, share {:.2f} agreement {:.2f} dominant {:.2f} spread {:.2f} "
              "chance {:.2f} {}\n",
              c.component, c.vertex, evidence, c.frame.verified ? "verified" : "refused",
              EdgeDistance(graph, edges, s.camera, pose, reference[i]),
              ExplainedEvidence(c.frame.verification), c.frame.verification.share,
              c.frame.verification.agreement, c.frame.verification.dominant_share,
              c.frame.verification.spread, c.frame.verification.chance, c.frame.verification.why);
        }
      }
    }
  }
  const double n = s.count;
  fmt::print(
      "| {} | {} | {}/{} | {} | {} | {} | {:.1f} | {:.1f}, {:.1f}, {:.1f}, {:.1f} | {:.0f} | "
      "{:.0f} |\n",
      s.name, baseline ? graph.name + " (chamfer baseline)" : graph.name, right, s.count, wrong,
      missed, Num(Median(errors)), Median(ms), sum.segment_ms / n, sum.orientation_ms / n,
      sum.ranking_ms / n, sum.tracking_ms / n, sum.junctions / n, sum.poses / n);
}

int main(int argc, char** argv) {
  CLI::App app{"cfuse's tracker and ViSP's on visp-images-data's sequences"};
  std::string names = "castle-simu,castel", csv_dir;
  std::vector<int> steps = {1, 2, 3};
  int repeat = 3, perturb = 0;
  double perturb_mm = 60, perturb_deg = 20;
  unsigned seed = 1;
  app.add_option("--sequences", names, "castle-simu, castel, cube (held back)");
  app.add_option("--steps", steps, "frame steps")->delimiter(',');
  app.add_option("--repeat", repeat, "runs per cell for the times");
  app.add_option("--perturb", perturb, "perturbed-start trials per sequence");
  app.add_option("--perturb-mm", perturb_mm, "the largest displacement of a perturbed start");
  app.add_option("--perturb-deg", perturb_deg, "the largest turn of a perturbed start");
  app.add_option("--seed", seed);
  app.add_option("--csv", csv_dir, "write each run's track here");
  bool segments = false;
  int jitter = 1;
  app.add_option("--jitter", jitter,
                 "cfuse runs per cell, each from the start moved by up to 1 mm and 0.3 degrees "
                 "(the first unmoved): a track's spread over nearly equal starts");
  app.add_flag("--segments", segments, "cfuse with segments for edge evidence too");
  bool use_depth = false;
  app.add_flag("--depth", use_depth,
               "cfuse and ViSP with the depth frames too, where a sequence has them (castel)");
  double depth_effective = 0;
  app.add_option("--depth-effective", depth_effective,
                 "the independent points cfuse's depth samples weigh as");
  int depth_stride = 0, depth_points = 0;
  app.add_option("--depth-points", depth_points, "cfuse's depth samples fused, at most");
  app.add_option("--depth-stride", depth_stride, "px between cfuse's depth samples");
  bool detect = false, verbose = false;
  app.add_flag("--detect", detect, "detection with no pose given on every frame, not tracking");
  app.add_flag("--verbose", verbose, "a line per frame (--detect)");
  bool show_candidates = false;
  app.add_flag("--show-candidates", show_candidates,
               "with --detect --verbose: each candidate tracked, and how far off");
  bool detect_after_loss = false;
  app.add_flag("--detect-after-loss", detect_after_loss,
               "cfuse's tracks detect the object after two frames lost, as `cfuse track` does");
  int candidates = 0;
  app.add_option("--candidates", candidates, "poses tracked per frame (--detect)");
  int settle_places = -1;
  app.add_option("--settle-places", settle_places,
                 "places on the ring about a found pose it is settled from (--detect)");
  bool chamfer = false;
  app.add_flag("--chamfer", chamfer,
               "with --detect: the baseline too, chamfer matching over a pose grid whose best "
               "poses the detector tracks and decides among (bench/chamfer_baseline.h)");
  bool support = false;
  app.add_flag("--support", support,
               "how much of the outline the image supports at cfuse's, the reference's and "
               "ViSP's poses, each frame measured alike");
  bool visp_scanline = false;
  app.add_flag("--visp-scanline", visp_scanline,
               "ViSP's edge tracker with its scan-line visibility test (off by default, as in "
               "ViSP)");
  std::string without;
  app.add_option("--without", without, std::string("safeguards off, comma-separated: ") +
                                           bench::kSafeguards);
  CLI11_PARSE(app, argc, argv);
  // cfuse's tracks, with detection after a loss (cfuse/track/auto_tracker.h) only when asked.
  AutoTrackerOptions options;
  if (!detect_after_loss) options.redetect_after = std::numeric_limits<int>::max();
  try {
    bench::DisableSafeguards(without, &options.tracker);
    if (depth_stride > 0) options.tracker.depth.stride = depth_stride;
    if (depth_effective > 0) options.tracker.depth.effective_points = depth_effective;
    if (depth_points > 0) options.tracker.depth.max_points = depth_points;
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "visp_sequences: {}\n", e.what());
    return 2;
  }

  std::vector<std::string> sequences;
  std::stringstream list(names);
  for (std::string n; std::getline(list, n, ',');) sequences.push_back(n);

  if (detect) {
    fmt::print("| sequence | model | found right | found wrong | not found | error median (mm) | "
               "ms a frame, median | split (segments and junctions, orientations, ranking, "
               "tracking) | junctions | poses ranked |\n|---|---|---|---|---|---|---|---|---|---|\n");
  } else fmt::print(
      "| sequence | k | tracker | frames verified | verified wrong | error median / worst (mm) | "
      "from ViSP's edges, median (mm) | ms a frame | after the first | split (evidence, "
      "prediction, search, estimation, verification) |\n|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<std::string> support_lines;  // --support
  for (const std::string& name : sequences) {
    Sequence s = Load(name);
    s.visp.scanline_visibility = visp_scanline;
    // The references without truth, ViSP's tracks with its scan-line test (without it, ViSP's
    // track of the cube strays up to 10 cm from them).
    Sequence with_scanline = s;
    with_scanline.visp.scanline_visibility = true;
    const std::vector<cv::Mat> frames = Frames(s);
    const ConstraintGraph graph = ImportCao(s.cao);
    const std::vector<ModelEdge> edges = ModelEdges(graph);
    // The reference: the truth, or ViSP's own track at step 1.
    std::vector<Rigid3d> reference = s.truth;
    std::vector<int> all(s.count);
    for (int k = 0; k < s.count; ++k) all[k] = k;
    std::vector<bench::DepthCloud> clouds;
    std::vector<DepthFrame> depth_frames;  // the same in the grey camera's frame, for cfuse
    if (!s.depth_format.empty()) {
      for (int k = 0; k < s.count; ++k) {
        const std::string file = fmt::format(fmt::runtime(s.depth_format), s.first + k);
        // In the depth camera's frame (ViSP's input) and moved into the grey camera's (cfuse's).
        const DepthFrame in_depth_camera =
            ReadRawDepth(file, s.depth_intrinsics, s.depth_unit, Rigid3d());
        clouds.push_back({in_depth_camera.width, in_depth_camera.height, in_depth_camera.points});
        depth_frames.push_back(
            ReadRawDepth(file, s.depth_intrinsics, s.depth_unit, s.depth_from_color.Inverse()));
      }
    }
    if (reference.empty() && !s.depth_format.empty()) {
      std::vector<const std::uint8_t*> pixels;
      for (int k = 0; k < s.count; ++k) pixels.push_back(frames[k].data);
      for (const bench::PeerFrame& f : bench::TrackWithVispDepth(
               pixels, 640, 480, s.camera, s.cao, s.start, with_scanline.visp, clouds,
               s.depth_config, s.depth_from_color)) {
        reference.push_back(f.camera_from_object);
      }
    }
    // ViSP's edges alone at step 1 too: the trajectory cfuse's should stay near.
    const std::vector<Rigid3d> visp_edges = TrackVisp(s, frames, all, s.start).poses;
    if (reference.empty()) {  // no truth, no depth (the cube): ViSP's edges
      reference = visp_scanline ? visp_edges : TrackVisp(with_scanline, frames, all, s.start).poses;
    }
    if (!csv_dir.empty()) {
      std::ofstream out(fs::path(csv_dir) / fmt::format("{}_reference.csv", name));
      out << "frame,x,y,z,qw,qx,qy,qz\n";
      for (size_t i = 0; i < reference.size(); ++i) {
        const Rigid3d& p = reference[i];
        out << fmt::format("{},{:.6f},{:.6f},{:.6f},{:.7f},{:.7f},{:.7f},{:.7f}\n", i,
                           p.translation.x(), p.translation.y(), p.translation.z(), p.rotation.w(),
                           p.rotation.x(), p.rotation.y(), p.rotation.z());
      }
    }
    if (detect) {
      DetectorOptions detector;
      if (candidates > 0) detector.max_candidates = candidates;
      if (settle_places >= 0) detector.tracker.settle_places = settle_places;
      DetectFrames(graph, edges, s, frames, reference, detector, verbose, show_candidates);
      if (chamfer) {
        const bench::ChamferBaseline baseline(graph, s.camera);
        fmt::print("(chamfer baseline: {} templates made in {:.0f} ms)\n", baseline.templates(),
                   baseline.training_ms());
        DetectFrames(graph, edges, s, frames, reference, detector, verbose, show_candidates,
                     &baseline);
      }
      continue;
    }
    for (int k : steps) {
      std::vector<int> picked;
      for (int i = 0; i < s.count; i += k) picked.push_back(i);
      for (const std::string who :
           {"cfuse", "cfuse (segments)", "cfuse + depth", "ViSP", "ViSP + depth"}) {
        if (who == "cfuse (segments)" && !segments) continue;
        const bool with_depth = who == "cfuse + depth" || who == "ViSP + depth";
        if (with_depth && (!use_depth || clouds.empty())) continue;
        const bool ours = who.starts_with("cfuse");
        const EdgeEvidence evidence =
            who == "cfuse (segments)" ? EdgeEvidence::kSegments : EdgeEvidence::kNormalSearch;
        const std::vector<DepthFrame>* depth = with_depth ? &depth_frames : nullptr;
        std::vector<double> means, later;  // ms a frame, and after the first frame
        Run run;
        std::vector<Run> runs;  // the jittered starts' (cfuse)
        std::mt19937 jitter_rng(seed);
        for (int j = 1; ours && j < jitter; ++j) {
          std::uniform_real_distribution<double> unit(-1, 1);
          const Eigen::Vector3d move(unit(jitter_rng), unit(jitter_rng), unit(jitter_rng));
          const Eigen::Vector3d turn(unit(jitter_rng), unit(jitter_rng), unit(jitter_rng));
          const Rigid3d start(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * M_PI / 180 * turn.norm(),
                                                                   turn.normalized())) *
                                  s.start.rotation,
                              s.start.translation + 0.001 * move);
          runs.push_back(TrackCfuse(graph, s, frames, picked, start, options, evidence, depth));
        }
        for (int r = 0; r < repeat; ++r) {
          run = ours ? TrackCfuse(graph, s, frames, picked, s.start, options, evidence, depth)
                : with_depth ? TrackVispDepth(s, frames, clouds, picked, s.start)
                             : TrackVisp(s, frames, picked, s.start);
          means.push_back(Mean(run.ms));
          later.push_back(Mean(std::vector<double>(run.ms.begin() + 1, run.ms.end())));
        }
        if (ours && support) {
          // The image's support for each track, measured alike: the outline's share with a
          // step within reach at the model's error of 1 px (verification.h), at every frame.
          const TrackerOptions fixed;
          auto share = [&](const Rigid3d& pose, const cv::Mat& m) {
            const GaussianState at = MakePrior(graph.blocks, Posed(graph, pose), {1e-6, 1e-6, 1});
            return VerifyOutline({m.data, m.cols, m.rows, static_cast<int>(m.step)},
                                 PredictEdges(graph, edges, at, s.camera, fixed.visibility, 1.0,
                                              fixed.min_edge_pixels),
                                 fixed.evidence_options.search, fixed.verification)
                .share;
          };
          double mine = 0, ref = 0, theirs = 0;
          int higher = 0;
          for (size_t i = 0; i < picked.size(); ++i) {
            const cv::Mat& m = frames[picked[i]];
            const double a = share(run.poses[i], m), b = share(reference[picked[i]], m);
            mine += a / picked.size();
            ref += b / picked.size();
            theirs += share(visp_edges[picked[i]], m) / picked.size();
            higher += a > b;
          }
          support_lines.push_back(fmt::format(
              "{} k = {}: the outline's share supported (model error 1 px), mean over the frames: "
              "{:.3f} at {}'s poses, {:.3f} at the reference's, {:.3f} at ViSP's edges'; "
              "{}'s above the reference's on {} of {} frames",
              name, k, mine, who, ref, theirs, who, higher, picked.size()));
        }
        std::vector<double> errors, from_visp;
        int accepted = 0, wrong = 0;
        runs.insert(runs.begin(), run);
        const size_t total = picked.size() * runs.size();
        for (size_t q = 0; q < total; ++q) {
          const Run& run = runs[q / picked.size()];
          const size_t i = q % picked.size();
          if (!run.accepted[i]) continue;
          ++accepted;
          const Rigid3d& ref = reference[picked[i]];
          const double mm = 1000 * (run.poses[i].translation - ref.translation).norm();
          const double px = EdgeDistance(graph, edges, s.camera, run.poses[i], ref);
          errors.push_back(mm);
          from_visp.push_back(
              1000 * (run.poses[i].translation - visp_edges[picked[i]].translation).norm());
          wrong += mm > 10 || px > 3;
        }
        const std::string split =
            ours ? fmt::format("{:.2f}, {:.2f}, {:.2f}, {:.2f}, {:.2f}", run.mean.segments,
                               run.mean.prediction, run.mean.search, run.mean.estimation,
                               run.mean.verification)
                 : "";
        fmt::print("| {} | {} | {} | {}/{} | {} | {} / {} | {} | {:.2f} | {:.2f} | {} |\n", name,
                   k, who, accepted, total, wrong, Num(Median(errors)),
                   Num(errors.empty() ? NAN : *std::max_element(errors.begin(), errors.end())),
                   s.truth.empty() ? Num(Median(from_visp)) : "", Median(means), Median(later),
                   split);
        if (!csv_dir.empty()) {
          std::string file = who;
          std::replace(file.begin(), file.end(), ' ', '_');
          file.erase(
              std::remove_if(file.begin(), file.end(), [](char c) { return c == '(' || c == ')'; }),
              file.end());
          std::ofstream out(fs::path(csv_dir) / fmt::format("{}_k{}_{}.csv", name, k, file));
          out << "frame,accepted,x,y,z,qw,qx,qy,qz,ms,share,chance,dominant,least,distance,"
                 "samples\n";
          for (size_t i = 0; i < picked.size(); ++i) {
            const Rigid3d& p = run.poses[i];
            const Verification v =
                run.verification.empty() ? Verification{} : run.verification[i];
            out << fmt::format(
                "{},{},{:.6f},{:.6f},{:.6f},{:.7f},{:.7f},{:.7f},{:.7f},{:.3f},{:.3f},{:.3f},{:.3f}"
                ","
                "{:.3f},{:.3f},{}\n",
                picked[i], run.accepted[i] ? 1 : 0, p.translation.x(), p.translation.y(),
                p.translation.z(), p.rotation.w(), p.rotation.x(), p.rotation.y(), p.rotation.z(),
                run.ms[i], v.share, v.chance, v.dominant_share, v.least_component, v.mean_distance,
                v.samples);
          }
        }
      }
    }
    if (perturb > 0) {
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> unit(0, 1);
      auto direction = [&] {
        Eigen::Vector3d v;
        do v = Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
        while (v.norm() < 1e-3 || v.norm() > 0.5);
        return v.normalized();
      };
      int frames_run = 0, verified = 0, wrong = 0, beyond_10_mm = 0;
      int peer_frames = 0, peer_wrong = 0, peer_final_within = 0, cfuse_final_within = 0;
      constexpr int kLength = 5;
      for (int trial = 0; trial < perturb; ++trial) {
        const int start = static_cast<int>(unit(rng) * (s.count - kLength));
        const Rigid3d& ref = reference[start];
        const double mm = perturb_mm * (0.1 + 0.9 * unit(rng)),
                     deg = perturb_deg * (0.1 + 0.9 * unit(rng));
        const Eigen::Quaterniond turn(Eigen::AngleAxisd(deg * M_PI / 180, direction()));
        const Rigid3d off(turn * ref.rotation, ref.translation + 0.001 * mm * direction());
        std::vector<int> picked;
        for (int i = start; i < start + kLength; ++i) picked.push_back(i);
        const Run run =
            TrackCfuse(graph, s, frames, picked, off, options, EdgeEvidence::kNormalSearch,
                       use_depth && !depth_frames.empty() ? &depth_frames : nullptr);
        // ViSP from the same start on the same frames: where edges alone take a tracker that
        // has no verification.
        const Run peer = TrackVisp(s, frames, picked, off);
        for (size_t i = 0; i < picked.size(); ++i) {
          const double err =
              1000 * (peer.poses[i].translation - reference[picked[i]].translation).norm();
          peer_frames += 1;
          peer_wrong += peer.accepted[i] && err > 10;
          peer_final_within += i + 1 == picked.size() && err <= 10;
        }
        cfuse_final_within +=
            run.accepted.back() &&
            1000 * (run.poses.back().translation - reference[picked.back()].translation).norm() <=
                10;
        for (size_t i = 0; i < picked.size(); ++i) {
          ++frames_run;
          if (!run.accepted[i]) continue;
          ++verified;
          const Rigid3d& truth = reference[picked[i]];
          const double err = 1000 * (run.poses[i].translation - truth.translation).norm();
          const double px = EdgeDistance(graph, edges, s.camera, run.poses[i], truth);
          beyond_10_mm += err > 10;
          if (err > 10 || px > 3) {
            ++wrong;
            const Verification& v = run.verification[i];
            fmt::print(
                stderr,
                "perturbed {} trial {} frame {} (its {}th): verified {:.1f} mm / {:.1f} px off "
                "(start {:.0f} mm {:.0f} deg; sigma {:.1f} mm agreement {:.2f} share {:.2f} "
                "chance {:.2f} dominant {:.2f} "
                "least {:.2f} distance {:.2f} n {}; depth fused {}, agreeing {:.2f}) pose {:.6f} "
                "{:.6f} {:.6f} {:.7f} {:.7f} "
                "{:.7f} {:.7f}; started at {:.6f} {:.6f} {:.6f} {:.7f} {:.7f} {:.7f} {:.7f}\n",
                name, trial, picked[i], i + 1, err, px, mm, deg, 1000 * run.position_sigma[i],
                v.agreement, v.share, v.chance, v.dominant_share, v.least_component,
                v.mean_distance, v.samples, run.depth_points[i], v.depth_share,
                run.poses[i].translation.x(), run.poses[i].translation.y(),
                run.poses[i].translation.z(), run.poses[i].rotation.w(), run.poses[i].rotation.x(),
                run.poses[i].rotation.y(), run.poses[i].rotation.z(), off.translation.x(),
                off.translation.y(), off.translation.z(), off.rotation.w(), off.rotation.x(),
                off.rotation.y(), off.rotation.z());
          }
        }
      }
      fmt::print(
          "\nperturbed starts, {}: {} trials, {} frames, {} verified, {} verified wrong ({} "
          "more than 10 mm off); within 10 mm at the trial's last frame: cfuse (verified) {}, "
          "ViSP {} (ViSP returned {} frames more than 10 mm off)\n\n",
          name, perturb, frames_run, verified, wrong, beyond_10_mm, cfuse_final_within,
          peer_final_within, peer_wrong);
    }
  }
  if (!support_lines.empty()) fmt::print("\n");
  for (const std::string& line : support_lines) fmt::print("{}\n", line);
  return 0;
}
