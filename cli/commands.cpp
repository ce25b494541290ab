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
#include <optional>
#include <sstream>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/constraints/graphviz.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/dsl/model_writer.h"
#include "cfuse/dsl/pose_reader.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/parametric.h"
#include "cfuse/interp/schedule.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/error.h"
#include "cfuse/kernel/evaluate.h"
#include "cli/answers.h"
#include "cli/command_support.h"
#include "cli/results.h"
#include "cli/summary.h"

namespace cfuse::cli {
namespace {

// Says a verdict's lines on `err`, each as the program's message; returns its status.
int Say(const Verdict& verdict, std::ostream& err) {
  for (const std::string& line : verdict.lines) err << "cfuse: " << line << "\n";
  return verdict.status;
}

}  // namespace

int RunCheck(const CheckCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const ModelSummary summary = Summarize(graph);
    std::optional<Solution> solution;
    if (!options.measurements.empty()) {
      const MeasurementSet set = ReadMeasurements(options.measurements);
      SolveOptions solve;
      solve.reject_outliers = true;
      solution = Solve(graph, set, solve);
    }
    if (options.json) {
      nlohmann::json json = SummaryJson(graph, summary);
      if (solution) {
        json["measurements"] = {{"degrees_of_freedom", solution->analysis.model_dof},
                                {"determined", solution->analysis.determined},
                                {"undetermined", solution->undetermined}};
      }
      out << JsonText(json, 2) << "\n";
    } else {
      PrintSummary(graph, summary, out);
      if (solution) {
        const FitAnalysis& a = solution->analysis;
        out << fmt::format("measurements ({}): determine {} of the model's {} degrees of freedom",
                           options.measurements, a.determined, a.model_dof);
        std::string names;
        for (const std::string& n : solution->undetermined)
          names += (names.empty() ? "" : ", ") + n;
        out << (names.empty() ? std::string("\n") : fmt::format("; undetermined: {}\n", names));
      }
    }
    return 0;
  });
}

int RunGraph(const GraphCommandOptions& options, std::ostream& out, std::ostream& err) {
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
    if (!options.output.empty()) RequireWritable(options.output);
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const MeasurementSet set = ReadMeasurements(options.measurements);
    std::optional<PoseSet> guess;
    if (!options.guess.empty()) guess = ReadPoses(options.guess);
    const SolveAnswer answer = SolveAndJudge(graph, set, options.method, guess ? &*guess : nullptr);
    const std::string text = JsonText(answer.result, 2) + "\n";
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    return Say(answer.verdict, err);
  });
}


int RunInterpret(const InterpretCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    for (const std::string* path : {&options.output, &options.tree}) {
      if (!path->empty()) RequireWritable(*path);
    }
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const MeasurementSet set = ReadMeasurements(options.measurements);
    InterpretOptions interpret;
    interpret.gate_confidence = options.gate;
    interpret.max_nodes = options.max_nodes;
    const InterpretAnswer answer = InterpretAndJudge(graph, set, interpret);
    if (answer.result.is_null()) return Say(answer.verdict, err);
    const std::string text = JsonText(answer.result, 2) + "\n";
    // The tree and the result both, or neither.
    OutputFiles files;
    if (!options.tree.empty()) files.Stage(options.tree, TreeDot(graph, answer.interpretation));
    if (!options.output.empty()) files.Stage(options.output, text);
    files.Commit();
    if (options.output.empty()) out << text;
    return Say(answer.verdict, err);
  });
}


int RunSimulate(const SimulateCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    RequireWritable(options.output);
    RequireWritable(options.truth);
    const ConstraintGraph graph = LoadAnyModel(options.model);
    SimulateOptions sim_options;
    sim_options.seed = options.seed;
    sim_options.noise = options.noise;
    sim_options.pixel_noise = options.pixel_noise;
    sim_options.clutter = options.clutter;
    sim_options.occlusion = options.occlusion;
    sim_options.labels = options.labels;
    sim_options.sample_joints = options.sample_joints;
    if (!options.camera.empty()) {
      sim_options.camera = LoadAnyCamera(options.camera);
      if (sim_options.camera->width <= 0 || sim_options.camera->height <= 0) {
        // ViSP's tracker settings give no size; the image bounds where the model and the clutter
        // are placed.
        throw InputError(SourceLocation(options.camera),
                         "the camera gives no image size (width and height), and simulate "
                         "places the model and the clutter inside the image: give a camera file "
                         "with one");
      }
    }
    const Simulation sim = Simulate(graph, sim_options);
    const std::string measurements = JsonText(MeasurementsJson(sim.measurements), 1) + "\n";
    const std::string truth = JsonText(TruthJson(graph, sim.truth, sim.matches), 1) + "\n";
    // The measurements and their truth both, or neither.
    OutputFiles files;
    files.Stage(options.output, measurements);
    files.Stage(options.truth, truth);
    files.Commit();
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

int RunImport(const ImportCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const std::string text = WriteModel(graph);
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    return 0;
  });
}

int RunFk(const FkCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    std::vector<JointValue> given;
    if (!options.joints.empty()) given = ReadJointValues(options.joints);
    const FkAnswer answer = ForwardKinematicsAndJudge(graph, given);
    if (answer.verdict.status != 0) return Say(answer.verdict, err);
    const std::string text = JsonText(answer.result, 2) + "\n";
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    return Say(answer.verdict, err);
  });
}

}  // namespace cfuse::cli
