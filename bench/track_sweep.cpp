// The tracker's benchmark (docs/benchmarks.md "Tracking"): speed, accuracy and robustness on
// rendered sequences with known truth (cfuse/vision/sequence.h's standard scenarios at 640 x 480),
// with ViSP's model-based edge tracker as a peer in the same run when it was built
// (bench/visp_tracker.h).
//
//   track_sweep [--frames 120] [--steps 1,2,3,4,5,6] [--seed 1] [--repeat 3] [--no-peer]
//
// Four tables, in Markdown:
//  1. Time per frame by stage for the hinged box (steady, k = 1), on one core, segment
//     detection included: the median over `repeat` runs of each stage's mean, and the frame
//     rate end to end.
//  2. Every scenario for the hinged box and the rigid box at k = 1: frames verified, errors.
//  3. The hinged box against the frame step k (every k-th frame: k times the motion).
//  4. The rigid box, cfuse and ViSP from the same true start on the same frames, against k.
// Errors are of the root component's origin (mm) and rotation (degrees), and of the first
// joint (degrees), over the verified frames (cfuse) or the frames ViSP tracked without
// throwing. "tracked" is the share of frames before the first whose estimate is off by more
// than 20 mm or 5 degrees, verified or not; "wrong" counts frames verified (or, for ViSP,
// returned) with the root more than 10 mm or 5 degrees off, or the first joint 5 degrees.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <opencv2/core/utility.hpp>
#include <sstream>
#include <optional>
#include <string>
#include <vector>

#include "bench/sweep_main.h"
#include "bench/tracker_ablation.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/cao.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/track/tracker.h"
#include "cfuse/vision/sequence.h"
#include "cfuse/vision/texture.h"
#ifdef CFUSE_HAVE_VISP
#include "bench/visp_tracker.h"
#endif

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

std::string Num(double x, int digits = 2) {
  return std::isnan(x) ? "-" : fmt::format("{:.{}f}", x, digits);
}

// One tracker's run over a sequence's frames.
struct Result {
  int frames = 0, verified = 0, wrong = 0;
  int lost_at = -1;  // the first frame off by more than 20 mm or 5 degrees (-1: none)
  std::vector<double> t_mm, r_deg, q_deg, ms;
  FrameTimes mean;  // per frame

  std::string Tracked() const {
    return fmt::format("{:.0f} %", 100.0 * (lost_at < 0 ? frames : lost_at) / frames);
  }
  std::string Verified() const { return fmt::format("{:.0f} %", 100.0 * verified / frames); }
};

// Scores a frame's estimate against the truth; `accepted`: verified, or returned by the peer.
void Score(const ConstraintGraph& graph, const Values& estimate, const Values& truth, bool accepted,
           double ms, Result* out) {
  const Rigid3d& e = estimate.poses[0];
  const Rigid3d& t = truth.poses[0];
  const double t_mm = 1000 * (e.translation - t.translation).norm();
  const double r_deg = e.rotation.angularDistance(t.rotation) * 180 / M_PI;
  const double q_deg =
      graph.joints.empty()
          ? 0.0
          : std::abs(JointValues(graph, estimate)[0] - JointValues(graph, truth)[0]) * 180 / M_PI;
  const bool off = !(t_mm <= 20) || !(r_deg <= 5);
  if (off && out->lost_at < 0) out->lost_at = out->frames;
  ++out->frames;
  out->ms.push_back(ms);
  if (!accepted) return;
  ++out->verified;
  // Wrong: the root more than 10 mm or 5 degrees off, or the first joint more than 5 degrees (a
  // lid 5 degrees off is 20 mm off at its far edge).
  if (!(t_mm <= 10) || !(r_deg <= 5) || !(q_deg <= 5)) ++out->wrong;
  out->t_mm.push_back(t_mm);
  out->r_deg.push_back(r_deg);
  if (!graph.joints.empty()) out->q_deg.push_back(q_deg);
}

Result RunCfuse(const ConstraintGraph& graph, const std::vector<SequenceFrame>& frames,
                int step, const TrackerOptions& options) {
  Result out;
  Tracker tracker(graph, StandardCamera(), frames[0].truth, options);
  for (size_t i = 0; i < frames.size(); i += step) {
    const Rendering& r = frames[i].rendering;
    const TrackedFrame f = tracker.Track({r.pixels.data(), r.width, r.height, r.width});
    Score(graph, f.estimate.mean, frames[i].truth, f.verified, f.times.Total(), &out);
    out.mean.segments += f.times.segments;
    out.mean.prediction += f.times.prediction;
    out.mean.search += f.times.search;
    out.mean.estimation += f.times.estimation;
    out.mean.verification += f.times.verification;
  }
  const double n = out.frames;
  out.mean = {out.mean.segments / n, out.mean.prediction / n, out.mean.search / n,
              out.mean.estimation / n, out.mean.verification / n};
  return out;
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
    if (used == 0 || used != item.size() || k < 1) {
      throw std::invalid_argument("--steps: a frame step is a whole number from 1, found '" + item +
                                  "'");
    }
    out.push_back(k);
  }
  return out;
}

int Run(int argc, char** argv) {
  CLI::App app{"cfuse's tracker on rendered sequences, with ViSP's edge tracker as a peer"};
  int frames = 120, repeat = 3;
  unsigned seed = 1;
  std::string steps_text = "1,2,3,4,5,6";
  bool no_peer = false;
  std::string style_name = "plain";
  app.add_option("--frames", frames, "frames per sequence")->check(CLI::Range(12, 100000));
  app.add_option("--style", style_name, "the renders' style: plain or realistic");
  app.add_option("--steps", steps_text, "frame steps k, comma-separated");
  app.add_option("--seed", seed, "the rendering's seed");
  app.add_option("--repeat", repeat, "timing runs (the median is reported)")
      ->check(CLI::Range(1, 100));
  app.add_flag("--no-peer", no_peer, "leave ViSP out");
  std::string without;
  app.add_option("--without", without, std::string("safeguards off, comma-separated: ") +
                                           bench::kSafeguards);
  CLI11_PARSE(app, argc, argv);
  TrackerOptions options;
  try {
    bench::DisableSafeguards(without, &options);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "track_sweep: {}\n", e.what());
    return 2;
  }
  const std::vector<int> steps = ParseSteps(steps_text);
  const std::optional<RenderStyle> style = ParseRenderStyle(style_name);
  if (!style) {
    fmt::print(stderr, "track_sweep: unknown style '{}' (plain or realistic)\n", style_name);
    return 2;
  }
  const auto photographs =
      *style == RenderStyle::kRealistic
          ? std::make_shared<const std::vector<GrayImage>>(
                LoadPhotographs(VispPhotographPaths()))
          : nullptr;
  cv::setNumThreads(1);  // one core

  const ConstraintGraph hinged = LoadModel(CFUSE_SOURCE_DIR "/examples/hinged-box.yaml");
  const std::string cao = CFUSE_SOURCE_DIR "/tests/data/cao/file_box.cao";
  const ConstraintGraph box = ImportCao(cao);
  const Camera camera = StandardCamera();
  auto render = [&](const ConstraintGraph& graph, const std::string& scenario) {
    return RenderSequence(
        graph, camera,
        StandardSequence(graph, scenario, frames, seed, *style, photographs));
  };

  // 1. Time by stage.
  const std::vector<SequenceFrame> steady = render(hinged, "steady");
  std::vector<Result> runs;
  for (int i = 0; i < repeat; ++i) runs.push_back(RunCfuse(hinged, steady, 1, options));
  auto median_of = [&](auto field) {
    std::vector<double> v;
    for (const Result& r : runs) v.push_back(field(r));
    return Median(v);
  };
  const double total = median_of([](const Result& r) { return r.mean.Total(); });
  fmt::print(
      "## Time per frame, hinged box (7 DOF), steady, 640 x 480, one core ({} frames, median "
      "of {} runs)\n\n",
      frames, repeat);
  fmt::print("| edges | prediction | search | estimation | verification | total | frames/s |\n");
  fmt::print("|---|---|---|---|---|---|---|\n");
  fmt::print("| {} | {} | {} | {} | {} | {} | {:.0f} |\n\n",
             Num(median_of([](const Result& r) { return r.mean.segments; }), 3),
             Num(median_of([](const Result& r) { return r.mean.prediction; }), 3),
             Num(median_of([](const Result& r) { return r.mean.search; }), 3),
             Num(median_of([](const Result& r) { return r.mean.estimation; }), 3),
             Num(median_of([](const Result& r) { return r.mean.verification; }), 3), Num(total, 3),
             1000 / total);
  fmt::print("(ms; the frame rate is 1000 / the mean total, image decoding not included)\n\n");

  // 2. Every scenario at k = 1.
  fmt::print("## Scenarios, k = 1 ({} frames, seed {})\n\n", frames, seed);
  fmt::print(
      "| model | scenario | median motion (px) | verified | wrong | median t (mm) | worst t (mm) "
      "| median R (°) | worst R (°) | median joint (°) | worst joint (°) | median ms |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& [name, graph] :
       {std::pair<const char*, const ConstraintGraph*>{"hinged", &hinged}, {"rigid", &box}}) {
    for (const std::string& scenario : StandardSequenceNames()) {
      const std::vector<SequenceFrame> sequence = render(*graph, scenario);
      const Result r = RunCfuse(*graph, sequence, 1, options);
      fmt::print("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", name, scenario,
                 Num(MedianImageMotion(*graph, sequence, camera), 1), r.Verified(), r.wrong,
                 Num(Median(r.t_mm)), Num(Max(r.t_mm)), Num(Median(r.r_deg)), Num(Max(r.r_deg)),
                 Num(Median(r.q_deg)), Num(Max(r.q_deg)), Num(Median(r.ms)));
      std::fflush(stdout);
    }
  }

  // 3. The hinged box against the step.
  fmt::print("\n## Hinged box against the frame step k (steady: {:.1f} px a frame at k = 1)\n\n",
             MedianImageMotion(hinged, steady, camera));
  fmt::print(
      "| k | frames | tracked | verified | wrong | median t (mm) | worst t (mm) | median R (°) "
      "| worst R (°) | median joint (°) | worst joint (°) | median ms |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int k : steps) {
    const Result r = RunCfuse(hinged, steady, k, options);
    fmt::print("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", k, r.frames,
               r.Tracked(), r.Verified(), r.wrong, Num(Median(r.t_mm)), Num(Max(r.t_mm)),
               Num(Median(r.r_deg)), Num(Max(r.r_deg)), Num(Median(r.q_deg)), Num(Max(r.q_deg)),
               Num(Median(r.ms)));
    std::fflush(stdout);
  }

  // 4. The rigid box, cfuse and ViSP.
#ifdef CFUSE_HAVE_VISP
  const bool peer = !no_peer;
#else
  const bool peer = false;
  if (!no_peer) fmt::print("\n(ViSP was not found when this was built: no peer columns)\n");
#endif
  const std::vector<SequenceFrame> rigid = render(box, "steady");
  fmt::print("\n## Rigid box against the frame step k: cfuse{}\n\n",
             peer ? " and ViSP's vpMbGenericTracker (edges, its tutorial settings)" : "");
  fmt::print(
      "| k | tracker | tracked | verified / ok | wrong | median t (mm) | worst t (mm) | "
      "median R (°) | worst R (°) | median ms |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|---|\n");
  for (int k : steps) {
    const Result r = RunCfuse(box, rigid, k, options);
    fmt::print("| {} | cfuse | {} | {} | {} | {} | {} | {} | {} | {} |\n", k, r.Tracked(),
               r.Verified(), r.wrong, Num(Median(r.t_mm)), Num(Max(r.t_mm)),
               Num(Median(r.r_deg), 3), Num(Max(r.r_deg), 3), Num(Median(r.ms)));
#ifdef CFUSE_HAVE_VISP
    if (peer) {
      std::vector<const std::uint8_t*> pixels;
      std::vector<const Values*> truth;
      for (size_t i = 0; i < rigid.size(); i += k) {
        pixels.push_back(rigid[i].rendering.pixels.data());
        truth.push_back(&rigid[i].truth);
      }
      const std::vector<bench::PeerFrame> track = bench::TrackWithVisp(
          pixels, camera.width, camera.height, camera, cao, rigid[0].truth.poses[0]);
      Result v;
      for (size_t i = 0; i < track.size(); ++i) {
        Values estimate = *truth[i];
        estimate.poses[0] = track[i].camera_from_object;
        Score(box, estimate, *truth[i], track[i].ok, track[i].ms, &v);
      }
      fmt::print("| {} | ViSP | {} | {} | {} | {} | {} | {} | {} | {} |\n", k, v.Tracked(),
                 v.Verified(), v.wrong, Num(Median(v.t_mm)), Num(Max(v.t_mm)),
                 Num(Median(v.r_deg), 3), Num(Max(v.r_deg), 3), Num(Median(v.ms)));
    }
#endif
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return cfuse::bench::SweepMain("track_sweep", Run, argc, argv); }
