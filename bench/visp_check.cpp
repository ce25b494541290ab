// Does ViSP's edge tracker, the tracking benchmark's peer (visp_tracker.h), track the file box,
// and up to which frame step?
//
//   visp_check [--frames 60] [--steps 1,2,3,4,5,6] [--cao tests/data/cao/file_box.cao]
//              [--range 8] [--threads 1] [--seed 1] [--verbose]
//
// It reads the box from its CAO file with cfuse's importer (one rigid component, `file_box`),
// renders a sequence of it (vision/sequence.h: 640 x 480, f = 800 px; the box's centre 1.2 m
// away, seen from above its left front corner so that its left, front and top faces show;
// its corners moving about 3.5 px a frame across the image and away, turning 0.4° a frame; 30
// clutter lines, noise 2 grey levels, blur 0.8 px), then for each step k tracks every k-th frame
// with ViSP from the true pose of frame 0. Per k it prints, as a Markdown row: the frames tracked
// ok (ViSP did not throw), the share of frames before the track is lost (the first frame whose
// translation error exceeds 20 mm or rotation error 5°), the median and worst errors over the
// frames tracked ok (translation of the box's origin, a corner, in mm; rotation in degrees),
// and the median time of ViSP's track() per frame.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/visp_tracker.h"
#include "importers/cao.h"
#include "kernel/error.h"
#include "vision/sequence.h"

namespace {

using namespace cfuse;

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double Max(const std::vector<double>& v) {
  return v.empty() ? NAN : *std::max_element(v.begin(), v.end());
}

double RotationErrorDeg(const Rigid3d& a, const Rigid3d& b) {
  return Eigen::AngleAxisd(a.rotation * b.rotation.conjugate()).angle() * 180 / M_PI;
}

// camera_from_box at frame 0: the camera looks at the box's centre along a direction from above
// its left front corner (box frame: -x left, -y front, +z top), the box's top up in the image;
// the centre lands at `centre_in_camera` (metres, camera frame).
Rigid3d StartPose(const Eigen::Vector3d& box_centre, const Eigen::Vector3d& centre_in_camera) {
  const Eigen::Vector3d forward = -Eigen::Vector3d(-1, -1.3, 0.9).normalized();
  const Eigen::Vector3d up_in_box = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d down = (-up_in_box + up_in_box.dot(forward) * forward).normalized();
  Eigen::Matrix3d camera_from_box;
  camera_from_box.row(0) = down.cross(forward);  // x right = y down x z forward
  camera_from_box.row(1) = down;
  camera_from_box.row(2) = forward;
  return Rigid3d(camera_from_box, centre_in_camera - camera_from_box * box_centre);
}

std::vector<int> ParseSteps(const std::string& text) {
  std::vector<int> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    size_t used = 0;
    int k = 0;
    try {
      k = std::stoi(item, &used);
    } catch (const std::logic_error&) {
      used = 0;
    }
    if (used == 0 || used != item.size()) {
      throw std::invalid_argument("a frame step must be a whole number, found '" + item + "'");
    }
    if (k < 1) throw std::invalid_argument("a frame step must be at least 1, found " + item);
    out.push_back(k);
  }
  return out;
}

int Run(int argc, char** argv) {
  CLI::App app{"ViSP's model-based edge tracker on a rendered sequence of the file box"};
  int frames = 60, seed = 1;
  std::string steps_text = "1,2,3,4,5,6";
  std::string cao = CFUSE_SOURCE_DIR "/tests/data/cao/file_box.cao";
  bench::VispOptions options;
  app.add_option("--frames", frames, "frames in the sequence")->check(CLI::Range(2, 10000));
  app.add_option("--steps", steps_text, "frame steps k, comma-separated: every k-th frame");
  app.add_option("--cao", cao, "the box's CAO model");
  app.add_option("--range", options.range, "ViSP's moving-edge search range (px)")
      ->check(CLI::Range(1, 100));
  app.add_option("--seed", seed, "the rendering's seed")->check(CLI::Range(0, 1 << 30));
  app.add_option("--threads", options.threads, "OpenMP threads ViSP may use (0: its default)")
      ->check(CLI::Range(0, 256));
  bool verbose = false;
  app.add_flag("--verbose", verbose, "also print every frame's errors");
  CLI11_PARSE(app, argc, argv);
  const std::vector<int> steps = ParseSteps(steps_text);

  const ConstraintGraph graph = importers::ImportCao(cao);
  const int component = graph.FindComponent("file_box");
  if (component < 0 || !graph.components[component].rigid) {
    throw std::invalid_argument("'" + cao + "' is not one rigid component named file_box");
  }
  const int pose_index = graph.blocks[graph.components[component].block].index;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const FeaturePoint& p : graph.components[component].points) centre += p.position;
  centre /= static_cast<double>(graph.components[component].points.size());

  Camera camera;
  camera.fx = camera.fy = 800;
  camera.cx = 320;
  camera.cy = 240;
  camera.width = 640;
  camera.height = 480;
  vision::SequenceSpec spec;
  spec.frames = frames;
  spec.start = StartPose(centre, {-0.15, -0.05, 1.2});
  spec.velocity = {0.0042, 0.0015, 0.0025};  // m a frame: ~3 px at 1.2 m, ~3.5 with the turn
  spec.spin = {0.002, 0.006, 0.002};         // rad a frame: 0.38°
  spec.render.seed = static_cast<unsigned>(seed);
  spec.render.clutter_lines = 30;
  spec.render.noise = 2;
  spec.render.blur = 0.8;
  const std::vector<vision::SequenceFrame> sequence = vision::RenderSequence(graph, camera, spec);

  // The image motion: each corner's displacement between consecutive frames.
  std::vector<double> motion;
  for (int i = 1; i < frames; ++i) {
    for (const FeaturePoint& p : graph.components[component].points) {
      const Eigen::Vector3d a = sequence[i - 1].truth.poses[pose_index] * p.position;
      const Eigen::Vector3d b = sequence[i].truth.poses[pose_index] * p.position;
      motion.push_back((camera.Project<double>(b) - camera.Project<double>(a)).norm());
    }
  }
  fmt::print(
      "file box ({}), {} frames of 640 x 480, f = 800 px, 1.2 m away: corners move {:.1f} px a "
      "frame (median; at most {:.1f})\n",
      cao, frames, Median(motion), Max(motion));
  fmt::print(
      "ViSP vpMbGenericTracker (edges): mask {} x {} masks, range {} px, threshold {}, mu {} / "
      "{}, sample step {} px\n\n",
      options.mask_size, options.mask_number, options.range, options.threshold, options.mu1,
      options.mu2, options.sample_step);

  fmt::print(
      "| step k | frames | ok | tracked | median t (mm) | worst t (mm) | median R (°) | worst R "
      "(°) | median ms/frame |\n|---|---|---|---|---|---|---|---|---|\n");
  for (int k : steps) {
    std::vector<const std::uint8_t*> pixels;
    std::vector<Rigid3d> truth;
    for (int i = 0; i < frames; i += k) {
      pixels.push_back(sequence[i].rendering.pixels.data());
      truth.push_back(sequence[i].truth.poses[pose_index]);
    }
    const std::vector<bench::PeerFrame> track =
        bench::TrackWithVisp(pixels, camera.width, camera.height, camera, cao, truth[0], options);
    std::vector<double> t_err, r_err, ms;
    int ok = 0;
    size_t lost_at = track.size();
    for (size_t i = 0; i < track.size(); ++i) {
      const double t = (track[i].camera_from_object.translation - truth[i].translation).norm();
      const double r = RotationErrorDeg(track[i].camera_from_object, truth[i]);
      if (lost_at == track.size() && (!(t <= 0.020) || !(r <= 5))) lost_at = i;
      ms.push_back(track[i].ms);
      if (verbose) {
        const Eigen::Vector3d d =
            1000 * (track[i].camera_from_object.translation - truth[i].translation);
        fmt::print(
            "k {} frame {:3d}: {} t error {:6.2f} mm (x {:6.2f} y {:6.2f} z {:6.2f}), R error "
            "{:.3f}°, {:.2f} ms\n",
            k, i * k, track[i].ok ? "ok  " : "LOST", d.norm(), d.x(), d.y(), d.z(), r, track[i].ms);
      }
      if (!track[i].ok) continue;
      ++ok;
      t_err.push_back(1000 * t);
      r_err.push_back(r);
    }
    fmt::print("| {} | {} | {} | {:.0f} % | {:.2f} | {:.2f} | {:.3f} | {:.3f} | {:.2f} |\n", k,
               track.size(), ok,
               100.0 * static_cast<double>(lost_at) / static_cast<double>(track.size()),
               Median(t_err), Max(t_err), Median(r_err), Max(r_err), Median(ms));
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const cfuse::InputError& e) {
    fmt::print(stderr, "visp_check: {}\n", e.what());
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "visp_check: {}\n", e.what());
  } catch (const std::runtime_error& e) {
    fmt::print(stderr, "visp_check: {}\n", e.what());
  }
  return 2;
}
