// The interpretation tree on seeded simulated data: one row of the sweep of issue 4.
//
//   interpret_sweep MODEL CLUTTER OCCLUSION TRIALS
//
// simulates TRIALS configurations of MODEL (seeds 100, 101, ...; 3D points, 2 mm noise, the
// given clutter ratio and occluded fraction), interprets each with the default options, and
// prints the share of trials with every match right, of real measurements matched right, the
// median nodes and the mean time. A match is right when it names the measurement's true model
// point; a clutter point is right when left unmatched.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <vector>

#include "dsl/model_loader.h"
#include "interp/interpretation.h"
#include "interp/simulate.h"
#include "interp/solve.h"

int main(int argc, char** argv) {
  if (argc != 5 && argc != 6) {
    fmt::print(stderr, "usage: interpret_sweep MODEL CLUTTER OCCLUSION TRIALS\n");
    return 2;
  }
  using namespace cfuse;
  const ConstraintGraph g = dsl::LoadModel(argv[1]);
  const double clutter = std::atof(argv[2]), occlusion = std::atof(argv[3]);
  const int trials = std::atoi(argv[4]);
  int all_right = 0, right = 0, real = 0, levels = 0;
  double total_ms = 0;
  std::vector<long> nodes;
  const int first = getenv("FIRST") ? atoi(getenv("FIRST")) : 0;
  for (int t = first; t < first + trials; ++t) {
    SimulateOptions so;
    so.seed = 100 + t;
    so.clutter = clutter;
    so.occlusion = occlusion;

    Simulation sim = Simulate(g, so);
    if (getenv("DBG")) {
      for (size_t m = 0; m < sim.matches.size(); ++m)
        sim.measurements.points[m].label = sim.matches[m];
    }
    if (getenv("DBGR")) {
      MeasurementSet labelled = sim.measurements;
      for (size_t m = 0; m < sim.matches.size(); ++m) labelled.points[m].label = sim.matches[m];
      const Solution sol = Solve(g, labelled);
      fmt::print(stderr, "truth solve: passes {} converged {} maxres {}\n", sol.summary.passes,
                 sol.summary.converged, sol.summary.max_constraint_residual);
    }
    const auto start = std::chrono::steady_clock::now();
    const Interpretation in = Interpret(g, sim.measurements);
    total_ms +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    bool all = true;
    for (size_t m = 0; m < sim.matches.size(); ++m) {
      all = all && in.matches[m] == sim.matches[m];
      if (!sim.matches[m].empty()) {
        ++real;
        right += in.matches[m] == sim.matches[m] ? 1 : 0;
      }
    }
    all_right += all ? 1 : 0;
    if (argc == 6) {
      fmt::print("trial {}: {} nodes {} expanded, seeds {} tried {}, matched {}, {}\n", t,
                 in.stats.nodes, in.stats.expanded, in.stats.seeds, in.stats.seeds_tried,
                 in.matched, all ? "right" : "WRONG");
      if (!all) {
        for (size_t m = 0; m < sim.matches.size(); ++m) {
          if (in.matches[m] != sim.matches[m]) {
            fmt::print("   m{}: truth '{}' found '{}'\n", m, sim.matches[m], in.matches[m]);
          }
        }
      }
    }
    nodes.push_back(in.stats.nodes);
    levels = in.stats.levels;
  }
  std::sort(nodes.begin(), nodes.end());
  fmt::print(
      "clutter {} occlusion {}: every match right {}/{}, matches right {}/{}, median "
      "nodes {} ({} levels), mean time {:.1f} ms\n",
      clutter, occlusion, all_right, trials, right, real,
      nodes.empty() ? 0 : nodes[nodes.size() / 2], levels, total_ms / trials);
  return 0;
}
