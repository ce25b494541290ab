// Are the answers right when they are given? A Monte Carlo sweep over models, data kinds and
// clutter (docs/benchmarks.md, "Right, wrong or refused").
//
//   answer_sweep MODEL... [--trials 50] [--first 0] [--verbose] [--commands solve,interpret]
//                [--data 3d,camera]
//
// For every model, from 3D points (2 mm noise) and from one 640 x 480 pinhole camera (1 px
// noise), without clutter (labelled points: `solve`) and with one clutter point per real one
// (unlabelled: `interpret`), TRIALS configurations are simulated (seeds 100, 101, ...; joint
// values drawn inside their limits, the closed chains closed) and each is estimated. A row per
// cell: the share of trials
//   - right: accepted (what the CLI answers with exit 0: converged, every constraint holding,
//     the fit test passed, nothing contradictory) and every component's position, and every
//     rigid component's orientation, within the 0.9999 chi-square gate of its reported
//     covariance (NEES < 21.1, 3 DOF each);
//   - ambiguous: accepted with alternatives said (the CLI warns that the data do not decide),
//     the answer beyond that gate but one of the alternatives inside it under the answer's
//     covariance (a symmetric or repeated part: the truth was offered);
//   - wrong: accepted but some component beyond that gate, and no alternative said is right
//     (the target is 0);
//   - refused: not accepted (exit 1, with the reason);
// the share with alternatives reported, the share with a valley named (Solution::valleys: a
// part whose fit stays acceptable far along its tilt, the covariance widened), and the mean NEES
// (positions and orientations) over the components of the right answers (3 when the covariance is
// honest).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <vector>

#include "bench/sweep_main.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "cfuse/vision/sequence.h"

namespace {

using namespace cfuse;

constexpr double kGate = 21.108;  // chi-square, 3 DOF, 0.9999

struct Tally {
  int trials = 0, right = 0, ambiguous = 0, wrong = 0, refused = 0, alternatives = 0, valleys = 0,
      failed_to_simulate = 0;
  double nees = 0;
  int nees_count = 0;
};

// The NEES of every component's position and, for a rigid one, of its orientation (the error
// in the pose's chart R <- R Exp(dθ)); single points count as components. Orientation matters
// where two components share an origin: the scissors' blades both sit on the pivot, and an
// answer with the blades exchanged has every position right. A covariance floor of (0.1 mm)²,
// or (0.1 mrad)², keeps a direction the constraints pin (a link's origin moves on a circle: its
// covariance has rank 1, and the estimate's second-order error leaves the circle by tens of
// µm) and a component the model fixes (covariance 0) from dividing that by zero; a wrong
// answer, off by millimetres there, still stands out.
std::vector<double> Nees(const ConstraintGraph& g, const Values& truth, const Values& mean,
                         const Eigen::MatrixXd& covariance) {
  std::vector<double> out;
  auto nees = [&](const Eigen::Vector3d& error, Eigen::Matrix3d cov) {
    cov += 1e-8 * Eigen::Matrix3d::Identity();
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(cov);
    const double n = ldlt.info() == Eigen::Success ? error.dot(ldlt.solve(error)) : HUGE_VAL;
    out.push_back(std::isfinite(n) ? n : HUGE_VAL);
  };
  for (const Component& c : g.components) {
    const Block& b = g.blocks[c.block];
    const int o = b.tangent_offset;
    if (c.rigid) {
      const Rigid3d& at = mean.poses[b.index];
      const Rigid3d& truly = truth.poses[b.index];
      nees(at.translation - truly.translation, covariance.block<3, 3>(o + 3, o + 3));
      const Eigen::AngleAxisd turn(truly.rotation.conjugate() * at.rotation);
      nees(turn.angle() * turn.axis(), covariance.block<3, 3>(o, o));
    } else {
      nees(mean.points[b.index] - truth.points[b.index], covariance.block<3, 3>(o, o));
    }
  }
  return out;
}

double WorstNees(const ConstraintGraph& g, const Values& truth, const Values& mean,
                 const Eigen::MatrixXd& covariance) {
  const std::vector<double> nees = Nees(g, truth, mean, covariance);
  return *std::max_element(nees.begin(), nees.end());
}

int Run(int argc, char** argv) {
  CLI::App app{"Right, wrong or refused: solve and interpret on simulated data"};
  std::vector<std::string> models;
  int trials = 50, first = 0;
  app.add_option("models", models, "model files")->required();
  app.add_option("--trials", trials, "configurations per cell")->check(CLI::Range(1, 100000));
  app.add_option("--first", first, "first trial (seed 100 + first)");
  bool verbose = false;
  app.add_flag("--verbose", verbose, "each wrong accepted answer on stderr");
  std::vector<std::string> commands = {"solve", "interpret"}, data = {"3d", "camera"};
  app.add_option("--commands", commands, "the cells' commands: solve, interpret (comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"solve", "interpret"}));
  app.add_option("--data", data, "the cells' data: 3d, camera (comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"3d", "camera"}));
  CLI11_PARSE(app, argc, argv);
  const auto listed = [](const std::vector<std::string>& list, const char* item) {
    return std::find(list.begin(), list.end(), item) != list.end();
  };

  const Camera pinhole = StandardCamera();  // 640 x 480, 800 px focal length

  fmt::print(
      "| model | data | clutter | command | trials | right | ambiguous, said | wrong, accepted | "
      "refused | alternatives | valleys | mean NEES (right) |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& file : models) {
    const ConstraintGraph g = LoadModel(file);
    for (const bool image : {false, true}) {
      if (!listed(data, image ? "camera" : "3d")) continue;
      for (const double clutter : {0.0, 1.0}) {
        if (!listed(commands, clutter == 0 ? "solve" : "interpret")) continue;
        Tally tally;
        for (int t = first; t < first + trials; ++t) {
          SimulateOptions so;
          so.seed = static_cast<unsigned>(100 + t);
          so.sample_joints = !g.joints.empty();
          so.clutter = clutter;
          so.labels = clutter == 0;
          if (image) so.camera = pinhole;
          Simulation sim;
          try {
            sim = Simulate(g, so);
          } catch (const InputError&) {
            ++tally.failed_to_simulate;  // no view puts the model inside the image
            continue;
          }
          ++tally.trials;
          // As `cfuse solve` and `cfuse interpret` run them.
          std::optional<Solution> solution;
          std::string mislabelled;  // interpret: each measurement labelled otherwise than truly
          if (clutter == 0) {
            SolveOptions options;
            options.reject_outliers = true;
            solution = Solve(g, sim.measurements, options);
          } else {
            InterpretOptions options;
            const Interpretation in = Interpret(g, sim.measurements, options);
            for (size_t m = 0; m < in.matches.size(); ++m) {
              if (!SameModelPlace(g, sim.truth, sim.matches[m], in.matches[m])) {
                mislabelled += fmt::format(" m{} '{}' as '{}';", m, sim.matches[m], in.matches[m]);
              }
            }
            if (in.Refusal().empty()) solution = in.solution;  // else refused, as the CLI does
          }
          if (!solution || !solution->accepted()) {
            ++tally.refused;
            continue;
          }
          if (!solution->alternatives.empty()) ++tally.alternatives;
          if (!solution->valleys.empty()) ++tally.valleys;
          const std::vector<double> nees =
              Nees(g, sim.truth, solution->state.mean, solution->state.covariance);
          const double worst = *std::max_element(nees.begin(), nees.end());
          const bool offered = std::any_of(
              solution->alternatives.begin(), solution->alternatives.end(),
              [&](const Solution::Alternative& a) {
                return WorstNees(g, sim.truth, a.mean, solution->state.covariance) < kGate;
              });
          if (worst < kGate) {
            ++tally.right;
            for (double e : nees) tally.nees += e;
            tally.nees_count += static_cast<int>(nees.size());
          } else if (offered) {
            ++tally.ambiguous;
          } else {
            ++tally.wrong;
            if (verbose) {
              // Per component: position error, orientation error and their NEES.
              std::string parts;
              size_t k = 0;  // into nees: two per rigid component, one per point
              for (size_t c = 0; c < g.components.size(); ++c) {
                const Block& b = g.blocks[g.components[c].block];
                if (g.components[c].rigid) {
                  const Rigid3d& at = solution->state.mean.poses[b.index];
                  const Rigid3d& truly = sim.truth.poses[b.index];
                  parts += fmt::format(" {} {:.1f} mm {:.1f} deg ({:.0f}, {:.0f});",
                                       g.components[c].name,
                                       1000 * (at.translation - truly.translation).norm(),
                                       at.rotation.angularDistance(truly.rotation) * 180 / M_PI,
                                       nees[k], nees[k + 1]);
                  k += 2;
                } else {
                  parts += fmt::format(
                      " {} {:.1f} mm ({:.0f});", g.components[c].name,
                      1000 * (solution->state.mean.points[b.index] - sim.truth.points[b.index])
                                 .norm(),
                      nees[k++]);
                }
              }
              double best_alternative = HUGE_VAL;
              for (const Solution::Alternative& a : solution->alternatives) {
                best_alternative = std::min(
                    best_alternative, WorstNees(g, sim.truth, a.mean, solution->state.covariance));
              }
              fmt::print(stderr,
                         "{} seed {}: accepted (p {:.3g}), worst NEES {:.1f};{} {} alternatives, "
                         "best NEES {:.1f}{}{}\n",
                         g.name, so.seed, solution->analysis.fit.p_value, worst, parts,
                         solution->alternatives.size(), best_alternative,
                         mislabelled.empty() ? "" : "; mislabelled:", mislabelled);
            }
          }
        }
        const double n = std::max(1, tally.trials);
        fmt::print(
            "| {} | {} | {} | {} | {}{} | {:.0f} % | {:.0f} % | {:.0f} % | {:.0f} % | {:.0f} % "
            "| {:.0f} % | {} |\n",
            g.name, image ? "one camera" : "3D points", clutter == 0 ? "none" : "1:1",
            clutter == 0 ? "solve" : "interpret", tally.trials,
            tally.failed_to_simulate
                ? fmt::format(" ({} views missed the image)", tally.failed_to_simulate)
                : "",
            100 * tally.right / n, 100 * tally.ambiguous / n, 100 * tally.wrong / n,
            100 * tally.refused / n, 100 * tally.alternatives / n, 100 * tally.valleys / n,
            tally.nees_count ? fmt::format("{:.2f}", tally.nees / tally.nees_count) : "-");
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return cfuse::bench::SweepMain("answer_sweep", Run, argc, argv); }
