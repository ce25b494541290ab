#include "cli/answers.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/parametric.h"
#include "cfuse/kernel/error.h"
#include "cfuse/kernel/evaluate.h"
#include "cli/results.h"

namespace cfuse::cli {
namespace {

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

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

// Why a solution whose fit is refused is refused.
std::string FitRefusal(const Solution& solution) {
  const Fit& fit = solution.analysis.fit;
  return fmt::format(
      "the measurements do not fit the estimate: chi-square {:.4g} over {} degrees of "
      "freedom (p {}, below 1e-3): a wrong match, a wrong model or noise larger than stated",
      fit.chi2, fit.dof,
      fit.p_value < 1e-15 ? std::string("< 1e-15") : fmt::format("= {:.2g}", fit.p_value));
}

// What the data leave free: its pose in the result is the start's, not the data's.
void NoteUndetermined(const Solution& solution, Verdict* verdict) {
  if (solution.undetermined.empty()) return;
  std::string names;
  for (const std::string& n : solution.undetermined) names += (names.empty() ? "" : ", ") + n;
  const int free = solution.analysis.model_dof - solution.analysis.determined;
  verdict->lines.push_back(fmt::format(
      "warning: the measurements and constraints leave {} direction{} undetermined, moving {}: "
      "their values are the start's, not the data's",
      free, free == 1 ? "" : "s", names));
}

// 1 when the solution's constraints do not hold or its measurements do not fit, else 0, with
// warnings naming what the data leave free and the other solutions that fit as well.
void JudgeSolution(const ConstraintGraph& graph, const Solution& solution, Verdict* verdict) {
  NoteUndetermined(solution, verdict);
  if (!solution.summary.converged) {
    verdict->lines.push_back(fmt::format("the constraints hold only to {:.3g} after {} passes{}",
                                         solution.summary.max_constraint_residual,
                                         solution.summary.passes,
                                         FarthestConstraint(graph, solution.state.mean)));
    verdict->status = 1;
    return;
  }
  if (!solution.alternatives.empty() && solution.fits) {
    std::string fits;
    for (const Solution::Alternative& a : solution.alternatives) {
      fits += fmt::format("{}chi-square {:.4g} (p = {:.2g})", fits.empty() ? "" : ", ", a.fit.chi2,
                          a.fit.p_value);
    }
    verdict->lines.push_back(fmt::format(
        "warning: the measurements fit {} other solution{} about as well ({}; this one "
        "{:.4g}): the data do not decide between them (\"alternatives\" in the result)",
        solution.alternatives.size(), solution.alternatives.size() == 1 ? "" : "s", fits,
        solution.analysis.fit.chi2));
  }
  for (const Solution::Valley& v : solution.valleys) {
    std::string how;
    if (v.towards_mirror > 0) {
      how = fmt::format("{:.1f} degrees towards its mirror image", v.towards_mirror * 180 / M_PI);
    }
    if (v.away > 0) {
      how += fmt::format("{}{:.1f} degrees away from it", how.empty() ? "" : " and ",
                         v.away * 180 / M_PI);
    }
    verdict->lines.push_back(fmt::format(
        "warning: '{}' can tilt {} with the fit still inside its 0.9999 interval, far beyond "
        "its local covariance: the covariance is widened to cover that valley (\"valleys\" in "
        "the result)",
        v.component, how));
  }
  if (!solution.fits) {
    verdict->lines.push_back(FitRefusal(solution));
    verdict->status = 1;
  }
}

}  // namespace

SolveAnswer SolveAndJudge(const ConstraintGraph& graph, const MeasurementSet& set,
                          const std::string& method, const PoseSet* guess) {
  if (method != "fusion" && method != "parametric" && method != "components") {
    throw InputError(SourceLocation("method"),
                     fmt::format("unknown method '{}' (fusion, parametric or components)", method));
  }
  if (std::none_of(set.points.begin(), set.points.end(),
                   [](const MeasuredPoint& p) { return !p.label.empty(); })) {
    throw InputError(SourceLocation(set.source),
                     "no labelled points: solve needs labels (unlabelled points are for "
                     "`cfuse interpret`)");
  }
  const auto start = std::chrono::steady_clock::now();
  Solution solution;
  std::optional<double> residual_variance;
  if (method == "parametric") {
    ParametricOptions parametric;
    parametric.guess = guess;
    ParametricSolution p = SolveParametric(graph, set, parametric);
    solution = std::move(p.solution);
    residual_variance = p.residual_variance;
  } else {
    SolveOptions solve_options;
    solve_options.guess = guess;
    solve_options.use_constraints_between_components = method != "components";
    solve_options.reject_outliers = true;
    solution = Solve(graph, set, solve_options);
  }
  SolveAnswer answer;
  answer.result = SolutionJson(graph, set, solution, MsSince(start));
  answer.result["status"]["method"] = method;
  if (method != "parametric") {
    answer.result["status"]["estimator"] = solution.estimator == Estimator::kReduced  ? "reduced"
                                           : solution.estimator == Estimator::kSparse ? "sparse"
                                                                                      : "filter";
  }
  if (residual_variance) {
    answer.result["status"]["residual_variance"] =
        std::isfinite(*residual_variance) ? nlohmann::json(*residual_variance) : nlohmann::json();
  }
  Verdict& verdict = answer.verdict;
  for (const Solution::Rejection& r : solution.rejected) {
    verdict.lines.push_back(fmt::format(
        "warning: measurement {} ({}) left out as an outlier: {:.3g} standard deviations from "
        "the estimate",
        r.measurement, set.points[r.measurement].label, r.sigmas));
  }
  if (!solution.invalid.empty()) {
    std::string what;
    for (const std::string& n : solution.invalid) what += (what.empty() ? "" : "; ") + n;
    verdict.lines.push_back(fmt::format("not fused, its residual not finite: {}", what));
    verdict.status = 1;
    return answer;
  }
  if (!solution.contradictions.empty()) {
    std::string names;
    for (const std::string& n : solution.contradictions) names += (names.empty() ? "" : ", ") + n;
    verdict.lines.push_back(
        fmt::format("contradictory constraints or measurements, not fused: {}", names));
    verdict.status = 1;
    return answer;
  }
  JudgeSolution(graph, solution, &verdict);
  return answer;
}

InterpretAnswer InterpretAndJudge(const ConstraintGraph& graph, const MeasurementSet& set,
                                  const InterpretOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  InterpretAnswer answer;
  answer.interpretation = Interpret(graph, set, options);
  const double ms = MsSince(start);
  const Interpretation& in = answer.interpretation;
  Verdict& verdict = answer.verdict;
  if (!in.solution) {
    verdict.lines.push_back(fmt::format(
        "no interpretation: no measurement matches a model point ({} of {} nodes, {})",
        in.stats.nodes, options.max_nodes, StatusName(in.stats.status)));
    verdict.status = 1;
    return answer;
  }
  answer.result = SolutionJson(graph, set, *in.solution, ms);
  answer.result["search"] = {
      {"status", StatusName(in.stats.status)},
      {"nodes", in.stats.nodes},
      {"nodes_expanded", in.stats.expanded},
      {"backtracks", in.stats.backtracks},
      {"levels", in.stats.levels},
      {"seeds", in.stats.seeds},
      {"seeds_tried", in.stats.seeds_tried},
      {"refinements", in.stats.refinements},
      {"predicted",
       in.stats.predicted >= 0 ? nlohmann::json(in.stats.predicted) : nlohmann::json(nullptr)},
      {"matched", in.matched},
      {"total_delta", in.total_delta}};
  if (in.stats.status == SearchStats::Status::kBudget) {
    verdict.lines.push_back(fmt::format(
        "the node budget ({}) ended the search: the best interpretation found so far is "
        "written",
        options.max_nodes));
  }
  JudgeSolution(graph, *in.solution, &verdict);
  if (verdict.status != 0) return answer;
  if (const std::string refusal = in.Refusal(); !refusal.empty()) {
    verdict.lines.push_back("no interpretation: " + refusal);
    verdict.status = 1;
  }
  return answer;
}

FkAnswer ForwardKinematicsAndJudge(const ConstraintGraph& graph,
                                   const std::vector<JointValue>& given) {
  FkAnswer answer;
  const std::map<std::string, double> q = CompleteJointValues(graph, given);
  for (const Joint& j : graph.joints) {
    const auto it = q.find(j.name);
    if (!j.limits || it == q.end()) continue;
    if (it->second < j.limits->first || it->second > j.limits->second) {
      const bool angle = !ModelOf(j.type).VariableIsLength();
      const double unit = angle ? 180 / M_PI : 1000;
      answer.verdict.lines.push_back(fmt::format(
          "warning: joint '{}' at {:.6g} {} is beyond its limits [{:.6g}, {:.6g}] {} ({})",
          j.name, it->second * unit, angle ? "deg" : "mm", j.limits->first * unit,
          j.limits->second * unit, angle ? "deg" : "mm", j.where.ToString()));
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
    answer.verdict.lines.push_back(
        fmt::format("the model's constraints cannot all hold at these joint values{}",
                    FarthestConstraint(graph, values)));
    answer.verdict.status = 1;
    return answer;
  }
  answer.result = PosesJson(graph, values);
  answer.result["joints"] = nlohmann::json::object();
  const bool moved = !std::equal(
      open.poses.begin(), open.poses.end(), values.poses.begin(),
      [](const Rigid3d& a, const Rigid3d& b) { return a.translation == b.translation; });
  const Eigen::VectorXd taken = JointValues(graph, values);
  int k = 0;
  for (const Joint& j : graph.joints) {
    if (!HasJointVariable(j.type)) continue;
    // The values as given where nothing moved (no rounding through the poses).
    answer.result["joints"][j.name] = {{"value", moved ? taken[k] : q.at(j.name)}};
    ++k;
  }
  return answer;
}

}  // namespace cfuse::cli
