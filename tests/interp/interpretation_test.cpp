// The interpretation tree: true matches found on seeded synthetic data, and every degenerate
// input ending in a clear status within the node budget.
#include "cfuse/interp/interpretation.h"

#include <fmt/format.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <optional>
#include <random>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/vision/sequence.h"
#include "interp/articulated.h"
#include "test_util.h"

namespace cfuse {
namespace {

using testing::ArticulatedAmongClutter;
using testing::OffersTruth;

struct Tally {
  int trials = 0, all_right = 0, right = 0, real = 0;
  int all_right_strict = 0;  // image data: labels exactly, or at one place
};

// Simulated models (seeds 100, 101, ...; the benchmark's, bench/interpret_sweep.cpp)
// interpreted; a match is right when it names the measurement's true model point (or one at
// its place, or in an image one projecting within 3 noise sigmas of it: simulate.h), and a
// clutter point is right when left unmatched.
Tally Run(const ConstraintGraph& g, int trials, double clutter, double occlusion,
          const std::optional<Camera>& camera = std::nullopt) {
  Tally t;
  InterpretOptions options;
  for (int i = 0; i < trials; ++i) {
    SimulateOptions so;
    so.seed = 100 + i;
    so.clutter = clutter;
    so.occlusion = occlusion;
    so.camera = camera;
    const Simulation sim = Simulate(g, so);
    const Interpretation in = Interpret(g, sim.measurements, options);
    bool all = true, all_strict = true;
    for (size_t m = 0; m < sim.matches.size(); ++m) {
      const bool strict = SameModelPlace(g, sim.truth, sim.matches[m], in.matches[m]);
      const std::optional<double> apart =
          camera ? ImageSeparation(g, sim.truth, *camera, sim.matches[m], in.matches[m])
                 : std::nullopt;
      const bool ok = strict || (apart && *apart <= 3 * so.pixel_noise);
      all = all && ok;
      all_strict = all_strict && strict;
      if (!sim.matches[m].empty()) {
        ++t.real;
        t.right += ok ? 1 : 0;
      }
    }
    ++t.trials;
    t.all_right += all ? 1 : 0;
    t.all_right_strict += all_strict ? 1 : 0;
  }
  return t;
}

TEST_CASE("interpret: the lamp's true matches among clutter", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  const Tally clean = Run(g, 10, 0, 0);
  CHECK(clean.all_right >= 9);
  const Tally cluttered = Run(g, 20, 1, 0);
  INFO("all right in " << cluttered.all_right << " of 20; " << cluttered.right << " of "
                       << cluttered.real << " matches");
  CHECK(cluttered.all_right >= 18);
  CHECK(cluttered.right >= 0.98 * cluttered.real);
  // The benchmark's key cell (docs/benchmarks.md): clutter 2, occlusion 10 %.
  const Tally key = Run(g, 20, 2, 0.1);
  INFO("clutter 2, occlusion 10 %: all right in " << key.all_right << " of 20; " << key.right
                                                  << " of " << key.real << " matches");
  CHECK(key.all_right >= 18);
  CHECK(key.right >= 0.99 * key.real);
}

TEST_CASE("interpret: the hinged box from 3D points and from one camera", "[interp][heavy]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const Tally points = Run(g, 20, 2, 0.1);
  INFO("3D, clutter 2, occlusion 10 %: all right in " << points.all_right << " of 20");
  CHECK(points.all_right >= 18);
  // From one camera (docs/benchmarks.md: 95 % all right without clutter, 73 % with strict labels,
  // the rest 10 mm lid corners a pixel or two apart).
  const Tally image = Run(g, 20, 1, 0, testing::Pinhole());
  INFO("2D, clutter 1: all right in " << image.all_right << " of 20 (" << image.all_right_strict
                                      << " strictly); " << image.right << " of " << image.real
                                      << " matches");
  CHECK(image.all_right >= 17);
  CHECK(image.right >= 0.95 * image.real);
}

TEST_CASE("interpret: the result is estimated from the matches and names the search", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  SimulateOptions so;
  so.seed = 7;
  so.clutter = 1;
  const Simulation sim = Simulate(g, so);
  const Interpretation in = Interpret(g, sim.measurements);
  REQUIRE(in.solution);
  CHECK(in.solution->summary.converged);
  CHECK(in.matched == 23);
  CHECK(in.stats.status == SearchStats::Status::kComplete);
  CHECK(in.stats.levels == 23);
  CHECK(in.stats.seeds_tried >= 1);
  REQUIRE(in.trace.size() == 23);
  // The dot file names every level and renders (tests/cli checks with `dot`).
  const std::string dot = TreeDot(g, in);
  CHECK(dot.find("level 23:") != std::string::npos);
}

// Matches that any points would fit are no answer: three clutter points matched to a pair of
// scissors seen by one camera fit exactly and leave its pose to the prior.
TEST_CASE("interpret: matches that cannot tell the object from clutter are refused", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  SimulateOptions so;
  so.seed = 3;
  so.clutter = 1;
  const Simulation sim = Simulate(g, so);
  Interpretation in = Interpret(g, sim.measurements);
  REQUIRE(in.solution);
  CHECK(in.Refusal().empty());  // every point matched: determined, and 2 of 3 rows to spare
  CHECK(in.solution->analysis.fit.dof > 0);
  // Cut short by the budget: an answer only when all model points but two were matched.
  in.stats.status = SearchStats::Status::kBudget;
  CHECK(in.Refusal().empty());
  const int all = in.matched;
  in.matched = all - 2;
  CHECK(in.Refusal().empty());
  in.matched = all - 3;
  CHECK(in.Refusal() == fmt::format("the node budget ended the search with {} of {} model points "
                                    "matched: the best interpretation so far is written, "
                                    "unverified (raise --max-nodes, or crop the data)",
                                    all - 3, in.assignment.size()));
  in.matched = all;
  in.stats.status = SearchStats::Status::kComplete;
  in.solution->undetermined = {"lid", "hinge"};
  CHECK(in.Refusal() == fmt::format("the {} matches leave lid, hinge undetermined: too few to "
                                    "tell the object from clutter",
                                    in.matched));
  in.solution->undetermined.clear();
  in.solution->analysis.fit.dof = 0;
  CHECK(in.Refusal().find("fit exactly, with no residual degrees of freedom") !=
        std::string::npos);
  in.solution->summary.converged = false;
  CHECK(in.Refusal() == "the estimate from the matches is not accepted");
  in.solution.reset();
  CHECK(in.Refusal() == "no measurement matches a model point");
}

TEST_CASE("interpret: degenerate inputs end in a clear status within the budget", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  SECTION("no measurements") {
    const Interpretation in = Interpret(g, MeasurementSet{});
    CHECK(in.matched == 0);
    CHECK_FALSE(in.solution);
    CHECK(in.stats.status == SearchStats::Status::kComplete);
  }
  SECTION("fewer measurements than a seed needs") {
    SimulateOptions so;
    so.seed = 3;
    Simulation sim = Simulate(g, so);
    sim.measurements.points.resize(2);
    InterpretOptions options;
    options.max_nodes = 2000;
    const Interpretation in = Interpret(g, sim.measurements, options);
    CHECK(in.stats.seeds == 0);
    CHECK(in.stats.nodes <= 2000);
    CHECK(in.matched <= 2);
  }
  SECTION("only clutter: the budget holds") {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    MeasurementSet set;
    for (int i = 0; i < 60; ++i) {
      MeasuredPoint m;
      m.xyz = Eigen::Vector3d(u(rng), u(rng), 1.5 + u(rng));
      m.cov3 = 4e-6 * Eigen::Matrix3d::Identity();
      set.points.push_back(m);
    }
    InterpretOptions options;
    options.max_nodes = 3000;
    const Interpretation in = Interpret(g, set, options);
    CHECK(in.stats.nodes <= 3000);
  }
  SECTION("every measurement twice") {
    SimulateOptions so;
    so.seed = 4;
    Simulation sim = Simulate(g, so);
    const size_t n = sim.measurements.points.size();
    for (size_t i = 0; i < n; ++i) sim.measurements.points.push_back(sim.measurements.points[i]);
    InterpretOptions options;
    options.max_nodes = 5000;
    const Interpretation in = Interpret(g, sim.measurements, options);
    CHECK(in.stats.nodes <= 5000);
    // Each model point is matched to one of its two copies.
    int right = 0;
    for (size_t m = 0; m < 2 * n; ++m) {
      if (!in.matches[m].empty() && in.matches[m] == sim.matches[m % n]) ++right;
    }
    CHECK(right >= 20);
  }
  SECTION("a budget of 10 nodes ends the search with that status") {
    SimulateOptions so;
    so.seed = 5;
    so.clutter = 2;
    const Simulation sim = Simulate(g, so);
    InterpretOptions options;
    options.max_nodes = 10;
    const Interpretation in = Interpret(g, sim.measurements, options);
    CHECK(in.stats.status == SearchStats::Status::kBudget);
    CHECK(in.stats.nodes <= 10);
  }
}

// A chain of identical segments (the folding ruler) among as many clutter points: a seed on
// the first segment says little about where the others swung, so it must not be ruled out by
// the points the nominal fold angles miss. Every answer accepted is right.
TEST_CASE("interpret: a folding ruler among clutter is right or refused", "[interp][heavy]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/folding-ruler.yaml"));
  int accepted = 0, wrong = 0;
  for (unsigned seed : {100u, 103u, 107u, 108u}) {  // each answered 270-400 mm off before
    const Simulation sim = ArticulatedAmongClutter(g, seed);
    const Interpretation in = Interpret(g, sim.measurements);
    if (!in.Refusal().empty()) continue;
    ++accepted;
    for (const Component& c : g.components) {
      const int i = g.blocks[c.block].index;
      const double off =
          (in.solution->state.mean.poses[i].translation - sim.truth.poses[i].translation).norm();
      if (off > 0.01) ++wrong;
    }
  }
  INFO(accepted << " of 4 accepted");
  CHECK(wrong == 0);
}

TEST_CASE("interpret: a reading that replaces the answer is re-associated under its own estimate",
          "[interp]") {
  // The folding ruler's seed 112 among clutter: the search reads the ruler from its other end,
  // and that reading read back (each segment turned end for end) fits better and becomes the
  // answer. It kept the reversed search's labels, though: s3's corner b measured but labelled
  // as s4's corner a beside it across the hinge, and s4's own a unmatched, the last segment 4 mm
  // off at a position NEES of 25. Refined under its own estimate, every label is right.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/folding-ruler.yaml"));
  const Simulation sim = ArticulatedAmongClutter(g, 112);
  const Interpretation in = Interpret(g, sim.measurements);
  REQUIRE(in.Refusal().empty());
  int mislabelled = 0, real = 0;
  for (size_t m = 0; m < sim.matches.size(); ++m) {
    mislabelled += SameModelPlace(g, sim.truth, sim.matches[m], in.matches[m]) ? 0 : 1;
    real += sim.matches[m].empty() ? 0 : 1;
  }
  CHECK(mislabelled == 0);
  CHECK(in.matched == real);
  CHECK(OffersTruth(sim, *in.solution));
}

// From one image, the first matches fix the pose and clutter fits them as well as the object:
// the flat scissors among as many clutter points were answered from 4 or 5 matches, 0 to 2 of
// them predicted before they were seen, 0.1 to 0.6 m off. Such an answer is refused; the same
// scissors from 3D points (every match after the seed predicted) are not.
TEST_CASE("interpret: an image answer with too few predicted matches is refused", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/scissors.yaml"));
  SimulateOptions so;
  so.sample_joints = true;
  so.clutter = 1;
  so.camera = StandardCamera();
  InterpretOptions options;
  for (unsigned seed : {113u, 114u, 140u}) {
    INFO("seed " << seed);
    so.seed = seed;
    const Interpretation in = Interpret(g, Simulate(g, so).measurements, options);
    REQUIRE(in.solution);
    CHECK(in.solution->accepted());  // the fit alone does not tell
    CHECK(in.stats.predicted >= 0);
    CHECK(in.stats.predicted < 3);
    CHECK_THAT(in.Refusal(), Catch::Contains("predicted before they were seen"));
  }
  const Interpretation in3 = Interpret(g, ArticulatedAmongClutter(g, 123).measurements);
  CHECK(in3.stats.predicted == -1);
  CHECK(in3.Refusal().empty());
}

// The scissors' blades lie 2 mm apart: seen in one image the pair is a near-planar object, with
// a second pose that projects nearly the same, near the mirror image of the first about the
// line of sight. Solved from the closed-form starts, this trial ended in that second minimum
// (blades 62 degrees off, p = 0.05) with no alternative said; the answer's own mirror image
// starts the truth's minimum, which fits better.
TEST_CASE("solve: a near-planar object from one image is started at its answer's mirror image",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/scissors.yaml"));
  SimulateOptions so;
  so.seed = 101;
  so.sample_joints = true;
  so.labels = true;
  so.camera = StandardCamera();
  const Simulation sim = Simulate(g, so);
  SolveOptions options;
  options.reject_outliers = true;
  const Solution solution = Solve(g, sim.measurements, options);
  REQUIRE(solution.accepted());
  for (size_t i = 0; i < solution.state.mean.poses.size(); ++i) {
    CHECK(solution.state.mean.poses[i].rotation.angularDistance(sim.truth.poses[i].rotation) <
          10 * M_PI / 180);  // 6 degrees, inside its covariance's gate; 62 before
  }
  // The other minimum, which the fit cannot reject; and where the blades' tilt runs on in a
  // valley beyond the covariance, its far end too (solve_valley_test.cpp).
  CHECK(solution.alternatives.size() >= 1);
  CHECK(solution.alternatives.size() <= 1 + 2 * solution.valleys.size());
  SolveOptions local = options;
  local.profile_valleys = false;
  CHECK(Solve(g, sim.measurements, local).alternatives.size() == 1);
}

// Seeded from a triangle that a right angle makes rigid (schedule_test.cpp): every point of
// the four matched among as many clutter points, from seeds rather than the unseeded search.
TEST_CASE("interpret: a model made rigid by a right angle and coplanarity is seeded",
          "[interp]") {
  const ConstraintGraph g =
      LoadModel(testing::SourcePath("tests/data/models/right-triangle.yaml"));
  for (unsigned seed : {1u, 2u, 3u}) {
    SimulateOptions so;
    so.seed = seed;
    so.clutter = 1;
    const Simulation sim = Simulate(g, so);
    const Interpretation in = Interpret(g, sim.measurements);
    CHECK(in.stats.seeds > 0);
    CHECK(in.Refusal().empty());
    CHECK(in.matches == sim.matches);
  }
}

TEST_CASE("interpret: an image answer accepted only just is solved again from solve's starts",
          "[interp]") {
  // The answer sweep's hinged box from one image, trial 126: the tree's labelling is right, but
  // the solve from the tree's estimate ends with the lid 25 degrees off, accepted at p = 0.02.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  SimulateOptions so;
  so.seed = 126;
  so.sample_joints = true;
  so.clutter = 1;
  so.camera = StandardCamera();
  const Simulation sim = Simulate(g, so);
  const int lid = g.blocks[g.components[1].block].index;
  auto lid_error = [&](const Values& v) {
    return v.poses[lid].rotation.angularDistance(sim.truth.poses[lid].rotation) * 180 / M_PI;
  };
  InterpretOptions options;
  InterpretOptions unexplored = options;
  unexplored.solve.explore_p_value = 0;
  const Interpretation before = Interpret(g, sim.measurements, unexplored);
  REQUIRE(before.solution);
  REQUIRE(before.solution->accepted());
  CHECK(before.solution->analysis.fit.p_value < options.solve.explore_p_value);
  CHECK(lid_error(before.solution->state.mean) > 15);  // what the exploration is for
  const Interpretation after = Interpret(g, sim.measurements, options);
  REQUIRE(after.solution);
  REQUIRE(after.solution->accepted());
  CHECK(after.matches == before.matches);  // the same labelling, another minimum
  CHECK(after.solution->analysis.fit.chi2 < before.solution->analysis.fit.chi2);
  CHECK(lid_error(after.solution->state.mean) < 5);
}

}  // namespace
}  // namespace cfuse
