// `cfuse demo`: the desk lamp of Hel-Or & Werman (1994), built in, simulated with clutter and
// occlusion, interpreted (which measurement is which point, and the constrained estimate), the
// matches checked against the truth, and a picture written; then Lowe's hinged box (1992)
// rendered opening and closing while it moves, tracked, and its overlay frames written.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/schedule.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "cfuse/track/tracker.h"
#include "cfuse/vision/point_picture.h"
#include "cfuse/vision/sequence.h"
#include "cli/command_support.h"
#include "cli/commands.h"
#include "cli/image_support.h"
#include "cli/summary.h"
#include "cli/track_overlay.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

// The tracking part: true when nearly every frame is verified.
bool DemoTracking(const DemoCommandOptions& options, std::ostream& out) {
  out << "\ncfuse demo, part 2: Lowe's hinged file box (1992), built in, tracked through a "
         "rendered sequence\n";
  const ConstraintGraph graph =
      LoadModelFromString(kEmbeddedHingedBoxYaml, "built-in examples/hinged-box.yaml", ".");
  // The overlays go to a sibling directory first, which replaces the old one at the end;
  // created before the frames are rendered, so that a path that cannot be one fails at once.
  const fs::path target =
      options.track_overlay.empty() ? fs::path() : fs::absolute(options.track_overlay);
  const fs::path partial = target.string() + ".partial";
  std::error_code ec;
  if (!target.empty()) {
    fs::remove_all(partial, ec);
    if (!fs::create_directories(partial, ec)) {
      throw InputError(SourceLocation(options.track_overlay),
                       "cannot create the directory: " + ec.message());
    }
  }
  const Camera camera = StandardCamera();
  constexpr int kFrames = 120;
  const SequenceSpec spec = StandardSequence(graph, "steady", kFrames, 7);
  const std::vector<SequenceFrame> frames = RenderSequence(graph, camera, spec);
  out << fmt::format(
      "render: {} frames of {} x {}, the box swaying and turning 1.3 m away, its lid swinging "
      "between {:.0f} and {:.0f} degrees, {} clutter lines, noise and blur\n",
      kFrames, camera.width, camera.height,
      (spec.joints.at("hinge").first - spec.joints.at("hinge").second) * 180 / M_PI,
      (spec.joints.at("hinge").first + spec.joints.at("hinge").second) * 180 / M_PI,
      spec.render.clutter_lines);

  Tracker tracker(graph, camera, frames[0].truth);
  std::vector<double> ms, t_mm, q_deg;
  int verified = 0;
  for (int i = 0; i < kFrames; ++i) {
    const Rendering& r = frames[i].rendering;
    const GrayView view{r.pixels.data(), r.width, r.height, r.width};
    const TrackedFrame f = tracker.Track(view);
    ms.push_back(f.times.Total());
    if (f.verified) {
      ++verified;
      t_mm.push_back(
          1000 *
          (f.estimate.mean.poses[0].translation - frames[i].truth.poses[0].translation).norm());
      q_deg.push_back(std::abs(JointValues(graph, f.estimate.mean)[0] -
                               JointValues(graph, frames[i].truth)[0]) *
                      180 / M_PI);
    }
    if (!target.empty()) {
      OverlayOptions overlay;
      overlay.caption = fmt::format("cfuse demo  frame {}  {}  {:.1f} ms", i,
                                    f.verified ? "verified" : "LOST", f.times.Total());
      try {
        WriteFileAtomically((partial / fmt::format("frame_{:05d}.png", i)).string(),
                            PngBytes(DrawOverlay(view, graph, camera, f, overlay)));
      } catch (...) {
        fs::remove_all(partial, ec);  // no half-written directory left behind
        throw;
      }
    }
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  auto worst = [](const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  };
  out << fmt::format(
      "track: {} of {} frames verified; box position error median {:.1f} mm, worst {:.1f} mm; "
      "lid angle error median {:.2f} deg, worst {:.2f} deg\n",
      verified, kFrames, median(t_mm), worst(t_mm), median(q_deg), worst(q_deg));
  out << fmt::format(
      "time per frame: median {:.2f} ms, worst {:.2f} ms (the search for edges "
      "included; {:.0f} frames a second)\n",
      median(ms), worst(ms), 1000 / std::max(1e-3, median(ms)));
  if (!target.empty()) {
    fs::remove_all(target, ec);
    fs::rename(partial, target, ec);
    if (ec) {
      const std::string why = ec.message();
      fs::remove_all(partial, ec);
      throw InputError(SourceLocation(options.track_overlay), "cannot write the directory: " + why);
    }
    out << fmt::format(
        "overlays: {}/frame_00000.png ... frame_{:05d}.png (yellow: verified, "
        "shaded: the predicted edges' 2-sigma regions, green: the matched image lines)\n",
        options.track_overlay, kFrames - 1);
  }
  return verified >= 0.9 * kFrames;
}

}  // namespace

int RunDemo(const DemoCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    // Refused before the demo runs: the picture's place, and an overlay path that is a file
    // (the overlay directory replaces what is there, and must not delete a file).
    RequireWritable(options.picture);
    if (std::error_code ec; !options.track_overlay.empty() &&
                            fs::exists(options.track_overlay, ec) &&
                            !fs::is_directory(options.track_overlay, ec)) {
      throw InputError(SourceLocation(options.track_overlay),
                       "cannot write: it is not a directory");
    }
    out << "cfuse demo: the desk lamp of Hel-Or & Werman (1994), built in\n\n";
    const ConstraintGraph graph =
        LoadModelFromString(kEmbeddedLampYaml, "built-in examples/lamp.yaml", ".");
    const ModelSummary summary = Summarize(graph);
    PrintSummary(graph, summary, out);

    // A random configuration at a random pose: 2 mm noise, 10 % of the points occluded, twice
    // as many clutter points as real ones, all unlabelled and shuffled.
    SimulateOptions sim_options;
    sim_options.seed = 2026;
    sim_options.noise = 0.002;
    sim_options.clutter = 2;
    sim_options.occlusion = 0.1;
    const Simulation sim = Simulate(graph, sim_options);
    const auto real = static_cast<int>(std::count_if(
        sim.matches.begin(), sim.matches.end(), [](const std::string& m) { return !m.empty(); }));
    out << fmt::format(
        "\nsimulate: {} unlabelled 3D points (sigma 2 mm): {} on the lamp ({} of its {} points "
        "occluded), {} clutter\n",
        sim.measurements.points.size(), real, graph.components.size() - real,
        graph.components.size(), sim.measurements.points.size() - real);

    InterpretOptions interpret;
    const auto start = std::chrono::steady_clock::now();
    const Interpretation in = Interpret(graph, sim.measurements, interpret);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    out << fmt::format(
        "interpret: {} points matched, {:.1f} ms ({} tree nodes, {} expanded; {} seed "
        "hypotheses, {} searched; search {})\n\n",
        in.matched, ms, in.stats.nodes, in.stats.expanded, in.stats.seeds, in.stats.seeds_tried,
        StatusName(in.stats.status));
    if (!in.solution) {
      err << "cfuse: demo: the interpretation matched nothing\n";
      return 1;
    }
    const Values& estimate = in.solution->state.mean;

    out << "point   measurement (truth)   matched   verdict     error of the estimate\n";
    int right = 0;
    double sum_estimate = 0, sum_measured = 0;
    int measured = 0;
    std::vector<PictureMarker> markers;
    for (size_t c = 0; c < graph.components.size(); ++c) {
      const std::string name = graph.components[c].name;
      const Eigen::Vector3d truth = ModelPoint(graph, sim.truth, static_cast<int>(c), -1);
      const Eigen::Vector3d fitted = ModelPoint(graph, estimate, static_cast<int>(c), -1);
      int true_m = -1, found_m = -1;
      for (size_t m = 0; m < sim.matches.size(); ++m) {
        if (sim.matches[m] == name) true_m = static_cast<int>(m);
        if (in.matches[m] == name) found_m = static_cast<int>(m);
      }
      const bool ok = true_m == found_m;
      right += ok ? 1 : 0;
      const char* verdict = !ok ? "WRONG" : true_m < 0 ? "occluded" : "right";
      out << fmt::format("{:<7} {:>19} {:>9}   {:<9} {:>10.2f} mm\n", name,
                         true_m < 0 ? "-" : fmt::format("m{}", true_m),
                         found_m < 0 ? "-" : fmt::format("m{}", found_m), verdict,
                         1000 * (fitted - truth).norm());
      if (found_m >= 0 && ok) {
        sum_measured += (sim.measurements.points[found_m].xyz - truth).squaredNorm();
        sum_estimate += (fitted - truth).squaredNorm();
        ++measured;
      }
      markers.push_back({fitted,
                         found_m < 0 ? PictureMarker::Kind::kOccluded
                                     : PictureMarker::Kind::kModelPoint,
                         name});
    }
    int clutter_matched = 0;
    for (size_t m = 0; m < sim.matches.size(); ++m) {
      const bool ok = sim.matches[m] == in.matches[m];
      if (sim.matches[m].empty() && !ok) ++clutter_matched;
      markers.push_back({sim.measurements.points[m].xyz,
                         !ok                      ? PictureMarker::Kind::kWrong
                         : sim.matches[m].empty() ? PictureMarker::Kind::kClutter
                                                  : PictureMarker::Kind::kMatched,
                         ""});
    }
    out << fmt::format(
        "\nmatches: {} of {} points right (matched, or occluded and left so), {} clutter points "
        "taken for the lamp\n",
        right, graph.components.size(), clutter_matched);
    if (measured > 0) {
      out << fmt::format(
          "RMS over the matched points: estimate {:.2f} mm, measurements {:.2f} mm "
          "(the constraints fused with the matches)\n",
          1000 * std::sqrt(sum_estimate / measured), 1000 * std::sqrt(sum_measured / measured));
    }

    // The picture: the fitted lamp drawn along its distance constraints.
    std::vector<PictureSegment> segments;
    for (const Constraint& k : graph.constraints) {
      const std::vector<int> comps = ConstraintComponents(graph, k);
      if (comps.size() == 2 && k.blocks.size() == 2) {
        segments.push_back(
            {ModelPoint(graph, estimate, comps[0], -1), ModelPoint(graph, estimate, comps[1], -1)});
      }
    }
    const std::string png = PointPicturePng(
        markers, segments,
        fmt::format("cfuse demo: desk lamp, {} measurements ({} clutter), {} of {} points right",
                    sim.measurements.points.size(), sim.measurements.points.size() - real, right,
                    graph.components.size()));
    // Staged, and committed once the tracking part's overlays are in place: a failure there
    // leaves no picture behind either.
    OutputFiles picture;
    picture.Stage(options.picture, png);
    out << fmt::format("picture: {}\n", options.picture);
    const bool lamp_ok = summary.violations.empty() && in.solution->summary.converged;
    const bool tracked = DemoTracking(options, out);
    picture.Commit();
    return lamp_ok && tracked ? 0 : 1;
  });
}

}  // namespace cfuse::cli
