// `cfuse demo`: the desk lamp of Hel-Or & Werman (1994), built in, simulated with clutter and
// occlusion, interpreted (which measurement is which point, and the constrained estimate), the
// matches checked against the truth, and a picture written.
#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "cli/command_support.h"
#include "cli/commands.h"
#include "cli/summary.h"
#include "dsl/model_loader.h"
#include "interp/interpretation.h"
#include "interp/schedule.h"
#include "interp/simulate.h"
#include "interp/solve.h"
#include "vision/pnp.h"
#include "vision/point_picture.h"

namespace cfuse::cli {

int RunDemo(const DemoOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    out << "cfuse demo: the desk lamp of Hel-Or & Werman (1994), built in\n\n";
    const ConstraintGraph graph =
        dsl::LoadModelFromString(kEmbeddedLampYaml, "built-in examples/lamp.yaml", ".");
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
    interpret.poses_from_three_projections = &vision::PosesFromThreeProjections;
    interpret.solve.pose_from_projections = &vision::PoseFromProjections;
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
    std::vector<vision::PictureMarker> markers;
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
                         found_m < 0 ? vision::PictureMarker::Kind::kOccluded
                                     : vision::PictureMarker::Kind::kModelPoint,
                         name});
    }
    int clutter_matched = 0;
    for (size_t m = 0; m < sim.matches.size(); ++m) {
      const bool ok = sim.matches[m] == in.matches[m];
      if (sim.matches[m].empty() && !ok) ++clutter_matched;
      markers.push_back({sim.measurements.points[m].xyz,
                         !ok                      ? vision::PictureMarker::Kind::kWrong
                         : sim.matches[m].empty() ? vision::PictureMarker::Kind::kClutter
                                                  : vision::PictureMarker::Kind::kMatched,
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
    std::vector<vision::PictureSegment> segments;
    for (const Constraint& k : graph.constraints) {
      const std::vector<int> comps = ConstraintComponents(graph, k);
      if (comps.size() == 2 && k.blocks.size() == 2) {
        segments.push_back(
            {ModelPoint(graph, estimate, comps[0], -1), ModelPoint(graph, estimate, comps[1], -1)});
      }
    }
    const std::string png = vision::PointPicturePng(
        markers, segments,
        fmt::format("cfuse demo: desk lamp, {} measurements ({} clutter), {} of {} points right",
                    sim.measurements.points.size(), sim.measurements.points.size() - real, right,
                    graph.components.size()));
    WriteFileAtomically(options.picture, png);
    out << fmt::format("picture: {}\n", options.picture);
    return summary.violations.empty() && in.solution->summary.converged ? 0 : 1;
  });
}

}  // namespace cfuse::cli
