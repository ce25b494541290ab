// Joint angles from markers, three estimators (and a peer) on the same data: the benchmark of issue
// 5 (docs/benchmarks.md).
//
//   robot_sweep MODEL... [--noise 0.001,0.003,0.01] [--trials 50] [--methods
//   fusion,unreduced,reduced,filter,parametric,components,ceres,sparse]
//
// For every MODEL (a URDF or a model file) it writes a model that includes it and fixes three
// markers on every component (a triangle 6-8 cm across about the component's frame, as a
// motion-capture rig would), then for every noise level simulates TRIALS configurations (seeds
// 100, 101, ...: joint variables uniform over the middle 80 % of their limits, a random base
// pose, the markers measured in 3D with that noise), and solves each with
//   - fusion: constraint fusion (cfuse/interp/solve.h), every joint a constraint: solve's
//     batch paths first (the joints eliminated below SolveOptions::reduced_below parameters,
//     else the sparse solver), the filter where they do not answer; from
//     SolveOptions::full_covariance_below state dimensions on, the covariance has no entries
//     between joints, and the NEES (marked ‡) is then each joint's alone, summed;
//   - unreduced: the same with no joint eliminated (SolveOptions::reduced_below 0): the sparse
//     solver, then the filter;
//   - reduced: the same with the joints eliminated at any size (reduced_below INT_MAX): where
//     the dense reduced solver stops paying;
//   - filter: the same with the sequential filter alone (SolveOptions::sparse_from_dim INT_MAX),
//     as `solve` ran before the sparse path;
//   - parametric: Lowe's estimator on root poses and joint variables (cfuse/interp/parametric.h);
//   - components: every component from its own markers alone, joints read off the poses;
//   - ceres: the parametric problem solved by Ceres, a peer (bench/ceres_robot.h; only where
//     Ceres was found at build time; its rows have no covariance, so no NEES);
//   - sparse: every marker and every constraint solved at once by the sparse solver
//     (cfuse/kernel/sparse_solver.h) from solve's closed-form start, with the covariance of
//     each component and of each joint's two components (what a joint's sigma needs): the
//     kernel alone, without solve's checks and fallbacks, and no NEES here.
// It prints a Markdown row per model, noise level and method: the trials that converged, the
// RMS error of the independent joint variables (angles in mrad; prismatic joints in mm), the
// mean NEES per joint (about 1 when the reported covariance is right), the RMS error of every
// model point (its feature points and markers, mm), and the median time per solve (the
// methods run in turn on each trial's data, in alternating order; run one method per process
// to time each alone, as docs/benchmarks.md does for both). A joint estimate held by an
// active inequality (its limit, or a range on points) has no variance and is left out of the
// NEES. Single-point components (the lamp's) are measured themselves.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "bench/sweep_main.h"
#ifdef CFUSE_HAVE_CERES
#include "bench/ceres_robot.h"
#endif
#include "cfuse/constraints/evaluate.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/urdf.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/parametric.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/measurements/point3.h"
#include "cfuse/kernel/sparse_solver.h"

namespace {

using namespace cfuse;
namespace fs = std::filesystem;

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

// The sparse method (see the top of the file). Its prior and tolerance are solve's.
struct SparseRobot {
  bool converged = false;
  Values mean;
};
SparseRobot SolveSparseRobot(const ConstraintGraph& g, const MeasurementSet& set) {
  const std::vector<ResolvedLabel> labels = ResolveLabels(g, set);
  Values start = ClosedFormStart(g, set, labels);
  MatchSlacks(g, &start);
  std::vector<Factor> factors;
  for (const ResolvedLabel& r : labels) {
    const MeasuredPoint& m = set.points[r.measurement];
    const Component& c = g.components[r.component];
    std::shared_ptr<const ResidualFunction> f;
    if (c.rigid) {
      f = std::make_shared<Point3Residual>(c.points[r.feature].position, m.xyz);
    } else {
      f = std::make_shared<Point3Residual>(m.xyz);
    }
    factors.push_back({f, {c.block}, Eigen::MatrixXd(m.cov3), m.label});
  }
  for (const Constraint& c : g.constraints) factors.push_back({c.residual, c.blocks, {}, c.name});
  std::vector<std::pair<int, int>> pairs;
  for (const Joint& j : g.joints) {
    if (j.parent >= 0 && j.child >= 0) {
      pairs.emplace_back(g.components[j.parent].block, g.components[j.child].block);
    }
  }
  const SolveOptions defaults;
  const double extent = ModelExtent(g);
  PriorScale scale;
  scale.position = defaults.prior_extent_factor * extent;
  scale.rotation = defaults.prior_rotation_sigma;
  scale.slack = defaults.prior_slack_sigma;
  SparseOptions options;
  options.constraint_tolerance = 1e-8 * extent;
  SparseEstimate estimate;
  const SparseSummary s = SolveSparse(factors, g.blocks, start, PriorVariance(g.blocks, scale),
                                      pairs, &estimate, options, &start);
  return {s.converged && s.max_constraint_residual <= options.constraint_tolerance,
          std::move(estimate.mean)};
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

LoadOptions WithUrdf() {
  LoadOptions options;
  options.include_handlers[".urdf"] = [](const std::string& path, const SourceLocation& where) {
    return ImportUrdf(path, where);
  };
  return options;
}

// `model` included by a model that adds three markers to every component.
ConstraintGraph WithMarkers(const std::string& model, const fs::path& dir) {
  const ConstraintGraph base =
      fs::path(model).extension() == ".urdf" ? ImportUrdf(model) : LoadModel(model, WithUrdf());
  fs::create_directories(dir);
  const fs::path path = dir / (fs::path(model).stem().string() + "-markers.yaml");
  std::ofstream out(path);
  out << "name: " << base.name << " with markers\nunits: {length: m, angle: rad}\n"
      << "include: " << fs::absolute(model).string() << "\nmarkers:\n";
  if (std::none_of(base.components.begin(), base.components.end(),
                   [](const Component& c) { return c.rigid; })) {
    out << "  {}\n";
  }
  for (const Component& c : base.components) {
    if (!c.rigid) continue;
    out << "  " << c.name << "_m1: {link: " << c.name << ", xyz: [0.06, 0.01, 0.02]}\n";
    out << "  " << c.name << "_m2: {link: " << c.name << ", xyz: [-0.02, 0.07, -0.01]}\n";
    out << "  " << c.name << "_m3: {link: " << c.name << ", xyz: [0.01, -0.03, 0.08]}\n";
  }
  out.close();
  return LoadModel(path.string(), WithUrdf());
}

// What a motion-capture rig sees: the markers, and single-point components (the lamp's points).
bool Measured(const ConstraintGraph& g, const std::string& label) {
  const size_t n = label.size();
  if (n > 3 && label[n - 3] == '_' && label[n - 2] == 'm') return true;
  const int c = g.FindComponent(label);
  return c >= 0 && !g.components[c].rigid;
}

struct Cell {
  int trials = 0, converged = 0;
  double angle_sq = 0, prismatic_sq = 0, point_sq = 0, nees = 0;
  int angles = 0, prismatics = 0, points = 0, dof = 0, on_limit = 0;
  std::vector<double> ms;
  std::vector<int> failed;  // trials that did not converge
  bool marginal = false;    // NEES of each joint alone (no covariance between joints)
};

// Adds one estimate's errors against the truth (its covariance's NEES only `with_covariance`).
void Score(const ConstraintGraph& g, const Values& truth, const GaussianState& estimate,
           bool converged, double ms, double noise, Cell* cell, bool with_covariance = true) {
  ++cell->trials;
  cell->ms.push_back(ms);
  if (!converged) {
    cell->failed.push_back(cell->trials - 1);
    return;
  }
  ++cell->converged;
  const JointEstimates q = EstimateJoints(g, estimate, true);
  Eigen::VectorXd e = q.values - JointValues(g, truth, true);
  for (int i = 0; i < e.size(); ++i) {
    if (g.joints[q.joints[i]].type == JointType::kPrismatic) {
      cell->prismatic_sq += e[i] * e[i];
      ++cell->prismatics;
    } else {
      e[i] = std::remainder(e[i], 2 * M_PI);
      cell->angle_sq += e[i] * e[i];
      ++cell->angles;
    }
  }
  // A joint held by an active inequality (its own limit, or a range on points: the scissors'
  // opening) has next to no variance: NEES over the others. Free, a joint's sigma is at least
  // about the noise over the markers' spread (0.1 m), so a thousandth of that means held.
  std::vector<int> free;
  for (int i = 0; i < e.size() && with_covariance; ++i) {
    const bool prismatic = g.joints[q.joints[i]].type == JointType::kPrismatic;
    const double floor = 1e-3 * (prismatic ? noise : noise / 0.1);
    const bool on_limit = q.covariance(i, i) < floor * floor;
    if (on_limit) {
      ++cell->on_limit;
    } else {
      free.push_back(i);
    }
  }
  Eigen::MatrixXd P(free.size(), free.size());
  Eigen::VectorXd ef(free.size());
  for (size_t a = 0; a < free.size(); ++a) {
    ef[a] = e[free[a]];
    for (size_t b = 0; b < free.size(); ++b) P(a, b) = q.covariance(free[a], free[b]);
  }
  if (P.allFinite()) {
    if (!free.empty()) cell->nees += ef.dot(P.ldlt().solve(ef));
  } else {
    // Solve's sparse path computes each joint's variance, not the pairs of joints: the NEES of
    // each joint alone, summed (also 1 per joint when the variances are right).
    for (int a = 0; a < ef.size(); ++a) cell->nees += ef[a] * ef[a] / P(a, a);
    cell->marginal = true;
  }
  cell->dof += static_cast<int>(free.size());
  for (size_t c = 0; c < g.components.size(); ++c) {
    if (!g.components[c].rigid) {
      const int ci = static_cast<int>(c);
      cell->point_sq +=
          (ModelPoint(g, estimate.mean, ci, -1) - ModelPoint(g, truth, ci, -1)).squaredNorm();
      ++cell->points;
    }
    for (size_t f = 0; f < g.components[c].points.size(); ++f) {
      const int ci = static_cast<int>(c), fi = static_cast<int>(f);
      cell->point_sq +=
          (ModelPoint(g, estimate.mean, ci, fi) - ModelPoint(g, truth, ci, fi)).squaredNorm();
      ++cell->points;
    }
  }
}

int Run(int argc, char** argv) {
  CLI::App app{
      "Joint angles from markers: constraint fusion, Lowe's parametric estimator and "
      "the per-component baseline (issue 5)"};
  std::vector<std::string> models;
  std::string noises = "0.001,0.003,0.01", methods = "fusion,parametric,components";
  int trials = 50;
  bool verbose = false;
  app.add_option("models", models, "URDF or model files")->required();
  app.add_option("--noise", noises, "3D marker noise sigmas, metres, comma-separated");
  app.add_option("--trials", trials, "trials per model and noise level")
      ->check(CLI::Range(1, 100000));
  int first = 0;
  app.add_option("--first", first, "first trial (seed 100 + first)");
  app.add_option("--methods", methods,
                 "fusion, unreduced, reduced, filter, parametric, components, ceres (where Ceres "
                 "was found "
                 "at build time), sparse");
  app.add_flag("--verbose", verbose, "list the trials that did not converge");
  CLI11_PARSE(app, argc, argv);
  for (const std::string& m : Split(methods)) {
#ifdef CFUSE_HAVE_CERES
    if (m == "ceres") continue;
#endif
    if (m != "fusion" && m != "unreduced" && m != "reduced" && m != "filter" && m != "parametric" &&
        m != "components" && m != "sparse") {
      throw std::invalid_argument("unknown method '" + m + "'");
    }
  }

  const fs::path dir = fs::temp_directory_path() / "cfuse_robot_sweep";
  fmt::print(
      "| model | joints | noise | method | converged | joint RMS (mrad) | prismatic RMS (mm) | "
      "NEES / joint | point RMS (mm) | time (median) |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& model : models) {
    const ConstraintGraph g = WithMarkers(model, dir);
    const std::string why = ParametricUnsupported(g);
#ifdef CFUSE_HAVE_CERES
    const std::string ceres_why = bench::CeresRobotUnsupported(g);
#endif
    int joints = 0;
    for (const Joint& j : g.joints) joints += HasJointVariable(j.type) && !j.mimic ? 1 : 0;
    for (const std::string& noise_text : Split(noises)) {
      const double noise = std::stod(noise_text);
      std::vector<Simulation> sims;
      for (int t = 0; t < trials; ++t) {
        SimulateOptions so;
        so.seed = 100 + first + t;
        so.noise = noise;
        so.labels = true;
        so.sample_joints = true;
        Simulation sim = Simulate(g, so);
        std::vector<MeasuredPoint> markers;
        for (const MeasuredPoint& p : sim.measurements.points) {
          if (Measured(g, p.label)) markers.push_back(p);
        }
        sim.measurements.points = std::move(markers);
        sims.push_back(std::move(sim));
      }
      // The methods that run on this model, each checked once.
      std::vector<std::string> run;
      for (const std::string& method : Split(methods)) {
        if (method == "parametric" && !why.empty()) {
          fmt::print("| {} | {} | {:g} mm | {} | no parametric form: {} | | | | | |\n", g.name,
                     joints, 1000 * noise, method, why);
          continue;
        }
#ifdef CFUSE_HAVE_CERES
        if (method == "ceres" && !ceres_why.empty()) {
          fmt::print("| {} | {} | {:g} mm | {} | not for the peer: {} | | | | | |\n", g.name,
                     joints, 1000 * noise, method, ceres_why);
          continue;
        }
        if (method == "ceres") {
          // The peer's kinematics must be the model's: the truth placed by them stays put.
          const double error = bench::CeresKinematicsError(g, sims.front().truth);
          if (!(error < 1e-9)) {
            throw std::logic_error(fmt::format(
                "the Ceres peer's kinematics miss the model's by {:.3g} m on {}", error, g.name));
          }
        }
#else
        if (method == "ceres") {
          fmt::print("| {} | {} | {:g} mm | {} | not built: Ceres was not found | | | | | |\n",
                     g.name, joints, 1000 * noise, method);
          continue;
        }
#endif
        run.push_back(method);
      }
      // Trial by trial, every method in turn on the same data, first to last and then last to
      // first: a method's time then does not depend on where it comes in the run (the
      // allocator's history, the caches, the machine's load).
      std::vector<Cell> cells(run.size());
      for (size_t t = 0; t < sims.size(); ++t) {
        const Simulation& sim = sims[t];
        for (size_t turn = 0; turn < run.size(); ++turn) {
          const size_t mi = t % 2 == 0 ? turn : run.size() - 1 - turn;
          const std::string& method = run[mi];
          Cell& cell = cells[mi];
          const auto start = std::chrono::steady_clock::now();
          GaussianState estimate;
          SparseRobot sparse;
          bool converged = false;
          bool with_covariance = true;
          if (method == "parametric") {
            ParametricSolution s = SolveParametric(g, sim.measurements);
            converged = s.converged;
            estimate = std::move(s.solution.state);
#ifdef CFUSE_HAVE_CERES
          } else if (method == "ceres") {
            bench::CeresRobotResult s = bench::SolveWithCeres(g, sim.measurements);
            converged = s.converged;
            estimate = MakePrior(g.blocks, s.values, PriorScale{});  // its mean; no covariance
            with_covariance = false;
#endif
          } else if (method == "sparse") {
            sparse = SolveSparseRobot(g, sim.measurements);
            converged = sparse.converged;
            with_covariance = false;
          } else {
            SolveOptions options;
            options.use_constraints_between_components = method != "components";
            if (method == "filter") options.sparse_from_dim = std::numeric_limits<int>::max();
            if (method == "unreduced") options.reduced_below = 0;
            if (method == "reduced") options.reduced_below = std::numeric_limits<int>::max();
            Solution s = Solve(g, sim.measurements, options);
            converged = s.summary.converged;
            estimate = std::move(s.state);
          }
          const double ms =
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                  .count();
          // Its mean only (see the top), and outside the time: a dense prior is not its cost.
          if (method == "sparse") estimate = MakePrior(g.blocks, sparse.mean, PriorScale{});
          Score(g, sim.truth, estimate, converged, ms, noise, &cell, with_covariance);
        }
      }
      for (size_t mi = 0; mi < run.size(); ++mi) {
        const std::string& method = run[mi];
        const Cell& cell = cells[mi];
        auto rms = [](double sq, int n) {
          return n ? fmt::format("{:.3f}", std::sqrt(sq / n)) : std::string("—");
        };
        fmt::print(
            "| {} | {} | {:g} mm | {} | {}/{} | {} | {} | {} | {} | {:.3f} ms |\n", g.name, joints,
            1000 * noise, method, cell.converged, cell.trials,
            cell.angles ? fmt::format("{:.3f}", 1000 * std::sqrt(cell.angle_sq / cell.angles))
                        : std::string("—"),
            cell.prismatics
                ? fmt::format("{:.3f}", 1000 * std::sqrt(cell.prismatic_sq / cell.prismatics))
                : std::string("—"),
            cell.dof ? fmt::format("{:.2f}{}", cell.nees / cell.dof, cell.marginal ? " ‡" : "")
                     : std::string("—"),
            rms(1e6 * cell.point_sq, cell.points), Median(cell.ms));
        if (verbose) {
          for (int t : cell.failed)
            fmt::print("   trial {} (seed {}) did not converge\n", t, 100 + first + t);
          if (cell.on_limit)
            fmt::print("   {} joint estimates held by an active inequality\n", cell.on_limit);
        }
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return cfuse::bench::SweepMain("robot_sweep", Run, argc, argv); }
