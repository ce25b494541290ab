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
#include "cli/command_support.h"
#include "cli/results.h"
#include "cli/summary.h"

namespace cfuse::cli {
namespace {

// "; farthest from holding: 'NAME' (FORMULA) at FILE:LINE:COLUMN, residual R", the constraint
// with the largest residual at `values`, or "" if none has one.
std::string FarthestConstraint(const ConstraintGraph& graph, const Values& values) {
  const Constraint* worst = nullptr;
  double largest = 0;
  Eigen::VectorXd r;
  for (const Constraint& c : graph.constraints) {
    EvaluateResidual(*c.residual, graph.blocks, c.blocks, values, &r, nullptr);
    const double size = r.allFinite() ? r.lpNorm<Eigen::Infinity>() : INFINITY;
    if (size > largest) {
      worst = &c;
      largest = size;
    }
  }
  if (!worst) return "";
  return fmt::format("; farthest from holding: '{}' ({}) at {}, residual {:.3g}", worst->name,
                     graph.Describe(*worst), worst->where.ToString(), largest);
}

// "cfuse: the measurements do not fit ...": why a solution whose fit is refused is refused.
std::string FitRefusal(const Solution& solution) {
  const Fit& fit = solution.analysis.fit;
  return fmt::format(
      "cfuse: the measurements do not fit the estimate: chi-square {:.4g} over {} degrees of "
      "freedom (p {}, below 1e-3): a wrong match, a wrong model or noise larger than stated",
      fit.chi2, fit.dof,
      fit.p_value < 1e-15 ? std::string("< 1e-15") : fmt::format("= {:.2g}", fit.p_value));
}

// A warning naming what the data leave free: its pose in the result is the start's, not the
// data's.
void ReportUndetermined(const Solution& solution, std::ostream& err) {
  if (solution.undetermined.empty()) return;
  std::string names;
  for (const std::string& n : solution.undetermined) names += (names.empty() ? "" : ", ") + n;
  err << fmt::format(
      "cfuse: warning: the measurements and constraints leave {} direction{} undetermined, "
      "moving {}: their values are the start's, not the data's\n",
      solution.analysis.model_dof - solution.analysis.determined,
      solution.analysis.model_dof - solution.analysis.determined == 1 ? "" : "s", names);
}

// The exit status of a solution whose result is written: 1 when its constraints do not hold
// or its measurements do not fit (why on stderr), else 0, with a warning naming what the data
// leave free.
int Verdict(const ConstraintGraph& graph, const Solution& solution, std::ostream& err) {
  ReportUndetermined(solution, err);
  if (!solution.summary.converged) {
    err << fmt::format("cfuse: the constraints hold only to {:.3g} after {} passes{}\n",
                       solution.summary.max_constraint_residual, solution.summary.passes,
                       FarthestConstraint(graph, solution.state.mean));
    return 1;
  }
  if (!solution.alternatives.empty() && solution.fits) {
    std::string fits;
    for (const Solution::Alternative& a : solution.alternatives) {
      fits += fmt::format("{}chi-square {:.4g} (p = {:.2g})", fits.empty() ? "" : ", ", a.fit.chi2,
                          a.fit.p_value);
    }
    err << fmt::format(
        "cfuse: warning: the measurements fit {} other solution{} about as well ({}; this one "
        "{:.4g}): the data do not decide between them (\"alternatives\" in the result)\n",
        solution.alternatives.size(), solution.alternatives.size() == 1 ? "" : "s", fits,
        solution.analysis.fit.chi2);
  }
  if (!solution.fits) {
    err << FitRefusal(solution) << "\n";
    return 1;
  }
  return 0;
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
    if (std::none_of(set.points.begin(), set.points.end(),
                     [](const MeasuredPoint& p) { return !p.label.empty(); })) {
      throw InputError(SourceLocation(options.measurements),
                       "no labelled points: solve needs labels (unlabelled points are for "
                       "`cfuse interpret`)");
    }
    std::optional<PoseSet> guess;
    if (!options.guess.empty()) guess = ReadPoses(options.guess);
    const auto start = std::chrono::steady_clock::now();
    Solution solution;
    std::optional<double> residual_variance;
    if (options.method == "parametric") {
      ParametricOptions parametric;
      parametric.guess = guess ? &*guess : nullptr;
      ParametricSolution p = SolveParametric(graph, set, parametric);
      solution = std::move(p.solution);
      residual_variance = p.residual_variance;
    } else {
      SolveOptions solve_options;
      solve_options.guess = guess ? &*guess : nullptr;
      solve_options.use_constraints_between_components = options.method != "components";
      solve_options.reject_outliers = true;
      solution = Solve(graph, set, solve_options);
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    nlohmann::json result = SolutionJson(graph, set, solution, ms);
    result["status"]["method"] = options.method;
    if (residual_variance) {
      result["status"]["residual_variance"] =
          std::isfinite(*residual_variance) ? nlohmann::json(*residual_variance) : nlohmann::json();
    }
    const std::string text = JsonText(result, 2) + "\n";
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    for (const Solution::Rejection& r : solution.rejected) {
      err << fmt::format(
          "cfuse: warning: measurement {} ({}) left out as an outlier: {:.3g} standard "
          "deviations from the estimate\n",
          r.measurement, set.points[r.measurement].label, r.sigmas);
    }
    if (!solution.invalid.empty()) {
      std::string what;
      for (const std::string& n : solution.invalid) what += (what.empty() ? "" : "; ") + n;
      err << fmt::format("cfuse: not fused, its residual not finite: {}\n", what);
      return 1;
    }
    if (!solution.contradictions.empty()) {
      std::string names;
      for (const std::string& n : solution.contradictions) names += (names.empty() ? "" : ", ") + n;
      err << fmt::format("cfuse: contradictory constraints or measurements, not fused: {}\n",
                         names);
      return 1;
    }
    return Verdict(graph, solution, err);
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
                        {"refinements", in.stats.refinements},
                        {"predicted", in.stats.predicted >= 0 ? nlohmann::json(in.stats.predicted)
                                                              : nlohmann::json(nullptr)},
                        {"matched", in.matched},
                        {"total_delta", in.total_delta}};
    const std::string text = JsonText(result, 2) + "\n";
    // The tree and the result both, or neither.
    OutputFiles files;
    if (!options.tree.empty()) files.Stage(options.tree, TreeDot(graph, in));
    if (!options.output.empty()) files.Stage(options.output, text);
    files.Commit();
    if (options.output.empty()) out << text;
    if (in.stats.status == SearchStats::Status::kBudget) {
      err << fmt::format(
          "cfuse: the node budget ({}) ended the search: the best interpretation "
          "found so far is written\n",
          options.max_nodes);
    }
    const int verdict = Verdict(graph, *in.solution, err);
    if (verdict != 0) return verdict;
    if (const std::string refusal = in.Refusal(); !refusal.empty()) {
      err << "cfuse: no interpretation: " << refusal << "\n";
      return 1;
    }
    return 0;
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
    const std::map<std::string, double> q = CompleteJointValues(graph, given);
    for (const Joint& j : graph.joints) {
      const auto it = q.find(j.name);
      if (!j.limits || it == q.end()) continue;
      if (it->second < j.limits->first || it->second > j.limits->second) {
        const bool angle = !ModelOf(j.type).VariableIsLength();
        const double unit = angle ? 180 / M_PI : 1000;
        err << fmt::format(
            "cfuse: warning: joint '{}' at {:.6g} {} is beyond its limits [{:.6g}, "
            "{:.6g}] {} ({})\n",
            j.name, it->second * unit, angle ? "deg" : "mm", j.limits->first * unit,
            j.limits->second * unit, angle ? "deg" : "mm", j.where.ToString());
      }
    }
    const Values open = ForwardKinematics(graph, q);
    Values values = open;
    // A closed chain: the given joints held, the others moved until every equality holds.
    std::map<std::string, double> held;
    for (const JointValue& v : given) {
      if (const int j = graph.FindJoint(v.name); j >= 0) {
        held[graph.joints[j].name] = q.at(graph.joints[j].name);
      }
    }
    if (!CloseLoops(graph, held, ModelExtent(graph), false, &values)) {
      err << fmt::format("cfuse: the model's constraints cannot all hold at these joint values{}\n",
                         FarthestConstraint(graph, values));
      return 1;
    }
    nlohmann::json result = PosesJson(graph, values);
    result["joints"] = nlohmann::json::object();
    const bool moved = !std::equal(
        open.poses.begin(), open.poses.end(), values.poses.begin(),
        [](const Rigid3d& a, const Rigid3d& b) { return a.translation == b.translation; });
    const Eigen::VectorXd taken = JointValues(graph, values);
    int k = 0;
    for (const Joint& j : graph.joints) {
      if (!HasJointVariable(j.type)) continue;
      // The values as given where nothing moved (no rounding through the poses).
      result["joints"][j.name] = {{"value", moved ? taken[k] : q.at(j.name)}};
      ++k;
    }
    const std::string text = JsonText(result, 2) + "\n";
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    return 0;
  });
}

}  // namespace cfuse::cli
