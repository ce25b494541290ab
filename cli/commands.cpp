#include "cli/commands.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>

#include "cli/results.h"
#include "cli/summary.h"
#include "constraints/graphviz.h"
#include "dsl/measurement_reader.h"
#include "dsl/model_loader.h"
#include "dsl/pose_reader.h"
#include "interp/interpretation.h"
#include "interp/schedule.h"
#include "interp/simulate.h"
#include "interp/solve.h"
#include "kernel/check.h"
#include "kernel/error.h"
#include "vision/pnp.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

// Runs a command, turning the error tiers into messages and exit statuses.
int Guarded(std::ostream& err, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    err << e.what() << "\n";
    return 2;
  } catch (const InternalError& e) {
    err << "cfuse: " << e.what() << "\n";
    return 3;
  } catch (const std::bad_alloc&) {
    err << "cfuse: error: out of memory\n";
    return 3;
  } catch (const std::exception& e) {
    err << "cfuse: internal error: " << e.what() << "\n";
    return 3;
  }
}

ConstraintGraph LoadAnyModel(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".yaml" && ext != ".yml") {
    throw InputError(SourceLocation(path),
                     fmt::format("unsupported model format '{}': model files are .yaml or .yml",
                                 ext.empty() ? "(no extension)" : ext));
  }
  return dsl::LoadModel(path);
}

// Writes `content` to `path` through a temporary file in the same directory, so that a
// failure never leaves a half-written file.
void WriteFileAtomically(const std::string& path, const std::string& content) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError(SourceLocation(path),
                     fmt::format("cannot write: directory '{}' does not exist", dir.string()));
  }
  if (fs::is_directory(target, ec)) {
    throw InputError(SourceLocation(path), "cannot write: it is a directory");
  }
  const fs::path temp = dir / fmt::format(".{}.tmp{}", target.filename().string(), ::getpid());
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << content;
    out.close();
    if (!out) {
      fs::remove(temp, ec);
      throw InputError(SourceLocation(path), "cannot write the file");
    }
  }
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw InputError(SourceLocation(path), fmt::format("cannot write: {}", ec.message()));
  }
}

}  // namespace

int RunCheck(const CheckOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const ModelSummary summary = Summarize(graph);
    if (options.json) {
      out << SummaryJson(graph, summary).dump(2) << "\n";
    } else {
      PrintSummary(graph, summary, out);
    }
    return 0;
  });
}

int RunGraph(const GraphOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    std::ostringstream dot;
    WriteDot(graph, dot);
    if (options.output.empty()) {
      out << dot.str();
    } else {
      WriteFileAtomically(options.output, dot.str());
    }
    return 0;
  });
}

int RunPlan(const PlanCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    out << FormatPlan(graph, PlanFusion(graph, options.image));
    return 0;
  });
}

int RunSolve(const SolveCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const MeasurementSet set = dsl::ReadMeasurements(options.measurements);
    if (std::none_of(set.points.begin(), set.points.end(),
                     [](const MeasuredPoint& p) { return !p.label.empty(); })) {
      throw InputError(SourceLocation(options.measurements),
                       "no labelled points: solve needs labels (unlabelled points are for "
                       "`cfuse interpret`)");
    }
    std::optional<PoseSet> guess;
    if (!options.guess.empty()) guess = dsl::ReadPoses(options.guess);
    const auto start = std::chrono::steady_clock::now();
    SolveOptions solve_options;
    solve_options.pose_from_projections = &vision::PoseFromProjections;
    solve_options.guess = guess ? &*guess : nullptr;
    const Solution solution = Solve(graph, set, solve_options);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const std::string text = SolutionJson(graph, set, solution, ms).dump(2) + "\n";
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    if (!solution.contradictions.empty()) {
      std::string names;
      for (const std::string& n : solution.contradictions) names += (names.empty() ? "" : ", ") + n;
      err << fmt::format("cfuse: contradictory constraints or measurements, not fused: {}\n",
                         names);
      return 1;
    }
    if (!solution.summary.converged) {
      err << fmt::format("cfuse: the constraints hold only to {:.3g} after {} passes\n",
                         solution.summary.max_constraint_residual, solution.summary.passes);
      return 1;
    }
    return 0;
  });
}

int RunInterpret(const InterpretCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const MeasurementSet set = dsl::ReadMeasurements(options.measurements);
    InterpretOptions interpret;
    interpret.gate_confidence = options.gate;
    interpret.max_nodes = options.max_nodes;
    interpret.poses_from_three_projections = &vision::PosesFromThreeProjections;
    interpret.solve.pose_from_projections = &vision::PoseFromProjections;
    const auto start = std::chrono::steady_clock::now();
    const Interpretation in = Interpret(graph, set, interpret);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!in.solution) {
      err << fmt::format(
          "cfuse: no interpretation: no measurement matches a model point ({} of {} nodes, {})\n",
          in.stats.nodes, options.max_nodes, StatusName(in.stats.status));
      return 1;
    }
    nlohmann::json result = SolutionJson(graph, set, *in.solution, ms);
    result["search"] = {{"status", StatusName(in.stats.status)},
                        {"nodes", in.stats.nodes},
                        {"nodes_expanded", in.stats.expanded},
                        {"backtracks", in.stats.backtracks},
                        {"levels", in.stats.levels},
                        {"seeds", in.stats.seeds},
                        {"seeds_tried", in.stats.seeds_tried},
                        {"matched", in.matched},
                        {"total_delta", in.total_delta}};
    const std::string text = result.dump(2) + "\n";
    const std::string dot = options.tree.empty() ? "" : TreeDot(graph, in);
    if (!options.tree.empty()) WriteFileAtomically(options.tree, dot);
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    if (in.stats.status == SearchStats::Status::kBudget) {
      err << fmt::format(
          "cfuse: the node budget ({}) ended the search: the best interpretation "
          "found so far is written\n",
          options.max_nodes);
    }
    return 0;
  });
}

int RunSimulate(const SimulateCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    SimulateOptions sim_options;
    sim_options.seed = options.seed;
    sim_options.noise = options.noise;
    sim_options.pixel_noise = options.pixel_noise;
    sim_options.clutter = options.clutter;
    sim_options.occlusion = options.occlusion;
    sim_options.labels = options.labels;
    if (!options.camera.empty()) sim_options.camera = dsl::ReadCameraFile(options.camera);
    const Simulation sim = Simulate(graph, sim_options);
    const std::string measurements = MeasurementsJson(sim.measurements).dump(1) + "\n";
    const std::string truth = TruthJson(graph, sim.truth, sim.matches).dump(1) + "\n";
    WriteFileAtomically(options.output, measurements);
    WriteFileAtomically(options.truth, truth);
    out << fmt::format(
        "simulated {} measurements of '{}' ({} real, {} clutter) -> {}, truth -> {}\n",
        sim.measurements.points.size(), graph.name,
        std::count_if(sim.matches.begin(), sim.matches.end(),
                      [](const std::string& m) { return !m.empty(); }),
        std::count_if(sim.matches.begin(), sim.matches.end(),
                      [](const std::string& m) { return m.empty(); }),
        options.output, options.truth);
    return 0;
  });
}

int RunDemo(std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    out << "cfuse demo: the desk lamp of Hel-Or & Werman (1994), built in\n\n";
    const ConstraintGraph graph =
        dsl::LoadModelFromString(kEmbeddedLampYaml, "built-in examples/lamp.yaml", ".");
    const ModelSummary summary = Summarize(graph);
    PrintSummary(graph, summary, out);

    // Simulate: a random configuration of the lamp at a random pose, 2 mm noise, one point
    // occluded; then solve from the labelled measurements.
    SimulateOptions sim_options;
    sim_options.seed = 2026;
    sim_options.noise = 0.002;
    sim_options.occlusion = 1.0 / 23;
    sim_options.labels = true;
    const Simulation sim = Simulate(graph, sim_options);
    const auto start = std::chrono::steady_clock::now();
    const Solution solution = Solve(graph, sim.measurements);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();

    out << fmt::format("\nsimulate: {} labelled 3D points (sigma 2 mm), {} occluded\n",
                       sim.measurements.points.size(),
                       graph.components.size() - sim.measurements.points.size());
    out << fmt::format("solve: {} passes, {:.2f} ms, largest constraint residual {:.1e}\n\n",
                       solution.summary.passes, ms, solution.summary.max_constraint_residual);
    out << "point   error of the estimate   error of the measurement   sigma of the estimate\n";
    double sum_estimate = 0, sum_measured = 0;
    int measured = 0;
    for (const Component& c : graph.components) {
      const Block& b = graph.blocks[c.block];
      const Eigen::Vector3d truth = sim.truth.points[b.index];
      const double e = (solution.state.mean.points[b.index] - truth).norm();
      const double sigma = std::sqrt(
          solution.state.covariance.block<3, 3>(b.tangent_offset, b.tangent_offset).trace());
      std::string m = "occluded";
      for (const MeasuredPoint& p : sim.measurements.points) {
        if (p.label == c.name) {
          m = fmt::format("{:.2f} mm", 1000 * (p.xyz - truth).norm());
          sum_measured += (p.xyz - truth).squaredNorm();
          sum_estimate += e * e;
          ++measured;
        }
      }
      out << fmt::format("{:<7} {:>10.2f} mm {:>24} {:>21.2f} mm\n", c.name, 1000 * e, m,
                         1000 * sigma);
    }
    out << fmt::format(
        "\nRMS over the measured points: estimate {:.2f} mm, measurements {:.2f} mm\n",
        1000 * std::sqrt(sum_estimate / measured), 1000 * std::sqrt(sum_measured / measured));
    out << "The constraints hold to the residual above; fusing them with the measurements brings\n"
           "the error well below the measurements' own, and places the occluded point.\n";
    return summary.violations.empty() && solution.summary.converged ? 0 : 1;
  });
}

}  // namespace cfuse::cli
