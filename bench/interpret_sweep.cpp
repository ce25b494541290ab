// The interpretation tree on seeded simulated data: the sweep of issue 4 (docs/benchmarks.md).
//
//   interpret_sweep MODEL [--camera] [--clutter 0,1,2,5] [--occlusion 0,0.1,0.3]
//                   [--trials 200] [--first 0] [--configs improved,paper,components]
//                   [--verbose] [--repeat 1]
//
// For every cell (clutter ratio x occluded fraction) it simulates TRIALS configurations of
// MODEL (seeds 100, 101, ...: 3D points with 2 mm noise, or with --camera image points with
// 1 px noise in a 640 x 480 pinhole view), interprets each under every configuration, and
// prints a Markdown row per cell and configuration: the share of trials with every match
// right, the share of real measurements matched right, the nodes expanded (median and 95th
// percentile), the nodes evaluated (median) and the time of Interpret (median; with --repeat
// R each trial is interpreted R times and its fastest time counts, which filters out the
// pauses of a shared machine).
//
// A measurement is right when it is left unmatched and is clutter, or is matched to a model
// point at the place of its true one (two model points can share a place: the corners a
// hinge joins, which no data can tell apart). In an image, also when the two points' true
// projections are within 3 noise sigmas (3 px) of each other: the 10 mm lid of the hinged box
// seen nearly edge-on puts its two faces' corners 1-2 px apart, and a measurement cannot say
// which of them it is. The strict share (labels exactly, or at one place) is printed too.
//
// The model's fusion plans are made once and shared by every trial (InterpretOptions::plans): a
// trial's time is the interpretation's own.
//
// Configurations: "improved" (the defaults), "paper" (one match at a time: no joint
// compatibility, no probability order, no re-association, no postponed blind points, every
// null counted; Hel-Or & Werman's search), "components" (the paper's divide and conquer:
// constraints between components ignored); ablations, each one improvement off:
// "no-joint-compatibility", "no-probability-order", "no-refinement", "no-postpone-blind",
// "no-free-nulls", "no-alternatives" (no search for other interpretations as complete as the
// answer).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <vector>

#include "bench/sweep_main.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "cfuse/vision/sequence.h"

namespace {

using namespace cfuse;

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

std::vector<double> Numbers(const std::string& s) {
  std::vector<double> out;
  for (const std::string& item : Split(s)) out.push_back(std::stod(item));
  return out;
}

template <typename T>
T Quantile(std::vector<T> v, double q) {
  if (v.empty()) return T();
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}

InterpretOptions Config(const std::string& name) {
  InterpretOptions o;
  if (name == "paper") {
    o.joint_compatibility = false;
    o.probability_order = false;
    o.refine_rounds = 0;
    o.postpone_blind = false;
    o.free_evidenced_nulls = 0;
  } else if (name == "components") {
    o.use_constraints_between_components = false;
  } else if (name == "no-joint-compatibility") {
    o.joint_compatibility = false;
  } else if (name == "no-probability-order") {
    o.probability_order = false;
  } else if (name == "no-refinement") {
    o.refine_rounds = 0;
  } else if (name == "no-postpone-blind") {
    o.postpone_blind = false;
  } else if (name == "no-free-nulls") {
    o.free_evidenced_nulls = 0;
  } else if (name == "no-alternatives") {
    o.max_alternative_seeds = 0;
    o.max_symmetric_readings = 0;
  } else if (name != "improved") {
    throw std::invalid_argument("unknown configuration '" + name + "'");
  }
  return o;
}

}  // namespace

int Run(int argc, char** argv) {
  CLI::App app{"The interpretation sweep of issue 4"};
  std::string model, clutters = "0,1,2,5", occlusions = "0,0.1,0.3",
                     configs = "improved,paper,components";
  int trials = 200, first = 0, repeat = 1;
  bool camera = false, verbose = false;
  app.add_option("model", model, "model file")->required();
  app.add_flag("--camera", camera, "image points from a 640 x 480 pinhole camera");
  app.add_option("--clutter", clutters, "clutter ratios, comma-separated");
  app.add_option("--occlusion", occlusions, "occluded fractions, comma-separated");
  app.add_option("--trials", trials, "trials per cell");
  app.add_option("--first", first, "first trial (its seed is 100 + FIRST)");
  app.add_option("--configs", configs, "improved, paper, components");
  app.add_flag("--verbose", verbose, "a line per trial");
  app.add_option("--repeat", repeat,
                 "interpret each trial this many times; its time is the fastest (for profiling "
                 "and for timing on a busy machine)")
      ->check(CLI::Range(1, 1000));
  CLI11_PARSE(app, argc, argv);

  const ConstraintGraph g = LoadModel(model);
  const Camera pinhole = StandardCamera();  // 640 x 480, 800 px focal length

  fmt::print(
      "| model | data | clutter | occlusion | search | all right | matches right | nodes "
      "expanded (median, p95) | nodes evaluated (median) | time (median) |{}\n"
      "|---|---|---|---|---|---|---|---|---|---|{}\n",
      camera ? " all right, strict labels |" : "", camera ? "---|" : "");
  const std::vector<std::string> config_names = Split(configs);
  std::vector<InterpretOptions> config_options;
  // The model's plans, made once (as the paper's fusion order is) and kept for every trial.
  const PlanCache plans(g);
  for (const std::string& config : config_names) {
    config_options.push_back(Config(config));
    config_options.back().plans = &plans;
  }
  for (double clutter : Numbers(clutters)) {
    for (double occlusion : Numbers(occlusions)) {
      // Every configuration sees the same simulated trials, simulated once.
      std::vector<Simulation> sims;
      std::vector<double> pixel_noise;
      for (int t = first; t < first + trials; ++t) {
        SimulateOptions so;
        so.seed = 100 + t;
        so.clutter = clutter;
        so.occlusion = occlusion;
        if (camera) so.camera = pinhole;
        sims.push_back(Simulate(g, so));
        pixel_noise.push_back(so.pixel_noise);
      }
      for (size_t c = 0; c < config_names.size(); ++c) {
        const InterpretOptions& options = config_options[c];
        int all_right = 0, all_right_strict = 0, right = 0, real = 0;
        std::vector<long> expanded, evaluated;
        std::vector<double> ms;
        for (int i = 0; i < trials; ++i) {
          const int t = first + i;
          const Simulation& sim = sims[i];
          Interpretation in;
          double fastest = HUGE_VAL;
          for (int r = 0; r < repeat; ++r) {
            const auto start = std::chrono::steady_clock::now();
            in = Interpret(g, sim.measurements, options);
            fastest = std::min(fastest, std::chrono::duration<double, std::milli>(
                                            std::chrono::steady_clock::now() - start)
                                            .count());
          }
          ms.push_back(fastest);
          bool all = true, all_strict = true;
          for (size_t m = 0; m < sim.matches.size(); ++m) {
            const std::string &truth = sim.matches[m], &found = in.matches[m];
            const bool strict = SameModelPlace(g, sim.truth, truth, found);
            // In an image, two points projecting within 3 noise sigmas of each other cannot be
            // told apart by their measurements (a 10 mm plate seen nearly edge-on).
            const double apart =  // NaN when not comparable
                camera ? ImageSeparation(g, sim.truth, pinhole, truth, found).value_or(NAN) : NAN;
            const bool ok = strict || apart <= 3 * pixel_noise[i];
            all = all && ok;
            all_strict = all_strict && strict;
            if (!truth.empty()) {
              ++real;
              right += ok ? 1 : 0;
            }
            if (verbose && !ok) {
              fmt::print("   trial {} m{}: truth '{}' found '{}'\n", t, m, truth, found);
            } else if (verbose && !strict) {
              fmt::print("   trial {} m{}: truth '{}' found '{}', {:.2f} px apart\n", t, m, truth,
                         found, apart);
            }
          }
          all_right += all ? 1 : 0;
          all_right_strict += all_strict ? 1 : 0;
          expanded.push_back(in.stats.expanded);
          evaluated.push_back(in.stats.nodes);
          if (verbose) {
            fmt::print(
                "trial {}: {} nodes ({} expanded), seeds {} (tried {}), {} matched, {}, {:.2f} "
                "ms\n",
                t, in.stats.nodes, in.stats.expanded, in.stats.seeds, in.stats.seeds_tried,
                in.matched, all ? "right" : "WRONG", ms.back());
          }
        }
        fmt::print(
            "| {} | {} | {} | {:.0f} % | {} | {:.1f} % | {:.2f} % | {}, {} | {} | {:.2f} ms |{}\n",
            g.name, camera ? "2D" : "3D", clutter, 100 * occlusion, config_names[c],
            100.0 * all_right / trials, real ? 100.0 * right / real : 100.0,
            Quantile(expanded, 0.5), Quantile(expanded, 0.95), Quantile(evaluated, 0.5),
            Quantile(ms, 0.5),
            camera ? fmt::format(" {:.1f} % |", 100.0 * all_right_strict / trials) : "");
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

int main(int argc, char** argv) {
  return cfuse::bench::SweepMain("interpret_sweep", Run, argc, argv);
}
