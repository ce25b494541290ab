// The tree itself (interp/src/interpreter_search.cpp), through Interpret: an occluded point's
// constraints wait until its neighbours place it, a point blind behind an occluded hub is
// postponed rather than branched on, and the search's options (Lowe's order, postponing, free
// nulls, joint compatibility) each leave the answer right.
#include <algorithm>
#include <catch2/catch.hpp>
#include <string>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/interp/simulate.h"
#include "test_util.h"

namespace cfuse {
namespace {

bool AllRight(const ConstraintGraph& g, const Simulation& sim, const Interpretation& in) {
  for (size_t m = 0; m < sim.matches.size(); ++m) {
    if (!SameModelPlace(g, sim.truth, sim.matches[m], in.matches[m])) return false;
  }
  return true;
}

// The lamp measured without `name`.
Simulation Without(const ConstraintGraph& g, const std::string& name, unsigned seed,
                   double clutter) {
  SimulateOptions so;
  so.seed = seed;
  so.clutter = clutter;
  Simulation sim = Simulate(g, so);
  const auto it = std::find(sim.matches.begin(), sim.matches.end(), name);
  REQUIRE(it != sim.matches.end());
  sim.measurements.points.erase(sim.measurements.points.begin() + (it - sim.matches.begin()));
  sim.matches.erase(it);
  return sim;
}

// The lamp's elbow side point p9 occluded: its constraints to its neighbours wait until they
// are matched, then place it; every other point is matched, and the answer puts p9 where it is.
TEST_CASE("search: an occluded point is placed by its neighbours, the rest matched", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  const int p9 = g.FindComponent("p9");
  for (unsigned seed : {21u, 22u}) {
    CAPTURE(seed);
    const Simulation sim = Without(g, "p9", seed, 1);
    const Interpretation in = Interpret(g, sim.measurements);
    CHECK(in.stats.status == SearchStats::Status::kComplete);
    CHECK(in.matched == 22);
    CHECK(AllRight(g, sim, in));
    REQUIRE(in.solution);
    CHECK(in.Refusal().empty());
    const double off =
        (ModelPoint(g, in.solution->state.mean, p9, -1) - ModelPoint(g, sim.truth, p9, -1)).norm();
    CHECK(off < 0.01);
  }
}

// The lamp with clutter and one hub point removed from the data: every constraint placing the
// wrist's side point p13 goes through the wrist p12, so with p12 occluded p13 is blind when its
// level comes (every measurement passes its gate). Postponed to the end of the branch, it is
// matched once p12 has been placed from its other neighbours.
TEST_CASE("interpret: a point blind behind an occluded hub is postponed, not branched on",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  long nodes_postponed = 0, nodes_branched = 0;
  int right = 0;
  const int trials = 8;
  for (int i = 0; i < trials; ++i) {
    SimulateOptions so;
    so.seed = 300 + i;
    so.clutter = 2;
    Simulation sim = Simulate(g, so);
    const auto hub = std::find(sim.matches.begin(), sim.matches.end(), "p12");
    REQUIRE(hub != sim.matches.end());
    sim.measurements.points.erase(sim.measurements.points.begin() + (hub - sim.matches.begin()));
    sim.matches.erase(hub);
    InterpretOptions options;
    options.max_nodes = 3000;
    const Interpretation in = Interpret(g, sim.measurements, options);
    bool all = in.stats.status == SearchStats::Status::kComplete;
    for (size_t m = 0; m < sim.matches.size(); ++m) {
      all = all && SameModelPlace(g, sim.truth, sim.matches[m], in.matches[m]);
    }
    right += all ? 1 : 0;
    nodes_postponed += in.stats.nodes;
    options.postpone_blind = false;
    nodes_branched += Interpret(g, sim.measurements, options).stats.nodes;
  }
  INFO("all right in " << right << " of " << trials << "; nodes " << nodes_postponed
                       << " postponed, " << nodes_branched << " branched");
  CHECK(right >= trials - 1);
  CHECK(nodes_postponed < nodes_branched);
}

// Each of the search's refinements of the paper's tree switched off alone, and all of them: the
// lamp among as many clutter points is still read right (they save nodes, not answers).
TEST_CASE("search: the paper's plain tree and each refinement find the same labels", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  SimulateOptions so;
  so.seed = 31;
  so.clutter = 1;
  const Simulation sim = Simulate(g, so);
  const Interpretation reference = Interpret(g, sim.measurements);
  REQUIRE(AllRight(g, sim, reference));
  InterpretOptions plain;
  plain.joint_compatibility = false;
  plain.probability_order = false;
  plain.postpone_blind = false;
  plain.free_evidenced_nulls = 0;
  plain.refine_rounds = 0;
  for (int off = 0; off < 5; ++off) {
    CAPTURE(off);
    InterpretOptions options;
    if (off == 0) options.joint_compatibility = false;
    if (off == 1) options.probability_order = false;
    if (off == 2) options.postpone_blind = false;
    if (off == 3) options.free_evidenced_nulls = 0;
    if (off == 4) options = plain;
    const Interpretation in = Interpret(g, sim.measurements, options);
    CHECK(in.stats.status == SearchStats::Status::kComplete);
    CHECK(in.matches == reference.matches);
  }
}

// The lamp is all single points, so a seed's bound (every point beyond its neighbours counted
// as possible) rules out almost no seed. Once an answer leaves no more points unmatched than
// occlusion explains, the seeds that follow are searched only while their support could beat
// it: the answers stay right and the seeds searched drop.
TEST_CASE("interpret: a nearly complete answer ends the search of less supported seeds",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  int right = 0, seeds_tried = 0;
  std::string trials_seen;
  const int trials = 8;
  for (int i = 0; i < trials; ++i) {
    SimulateOptions so;
    so.seed = 500 + i;
    so.clutter = 2;
    so.occlusion = 0.1;
    const Simulation sim = Simulate(g, so);
    const Interpretation in = Interpret(g, sim.measurements, InterpretOptions{});
    bool all = in.stats.status == SearchStats::Status::kComplete;
    for (size_t m = 0; m < sim.matches.size(); ++m) {
      all = all && SameModelPlace(g, sim.truth, sim.matches[m], in.matches[m]);
    }
    right += all ? 1 : 0;
    seeds_tried += in.stats.seeds_tried;
    trials_seen += "trial " + std::to_string(i) + ": " + std::to_string(in.stats.seeds_tried) +
                   " of " + std::to_string(in.stats.seeds) + " seeds searched" +
                   (all ? "\n" : ", labels wrong\n");
  }
  INFO(trials_seen << "all right in " << right << " of " << trials << "; seeds searched "
                   << seeds_tried);
  CHECK(right == trials);
  CHECK(seeds_tried <= 2 * trials);
}

}  // namespace
}  // namespace cfuse
