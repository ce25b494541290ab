// Other readings of a configuration by the model's symmetries: found where the model has them,
// each putting every point where a point was, and none where the model has none.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/solve.h"
#include "symmetric_readings.h"
#include "test_util.h"

namespace cfuse {
namespace {

ConstraintGraph Example(const char* file) {
  return LoadModel(testing::SourcePath(std::string("examples/") + file));
}

// Every point of every rigid component, in the reading, where its source point is in the
// configuration read.
double LargestPointMove(const ConstraintGraph& g, const Values& configuration,
                        const Reading& reading) {
  double largest = 0;
  for (size_t c = 0; c < g.components.size(); ++c) {
    if (!g.components[c].rigid) continue;
    for (size_t i = 0; i < g.components[c].points.size(); ++i) {
      const Eigen::Vector3d now =
          ModelPoint(g, reading.mean, static_cast<int>(c), static_cast<int>(i));
      const Eigen::Vector3d before = ModelPoint(g, configuration, reading.source_component[c],
                                                reading.source_point[c][i]);
      largest = std::max(largest, (now - before).norm());
    }
  }
  return largest;
}

TEST_CASE("symmetric readings: the scissors' blades exchanged", "[interp]") {
  const ConstraintGraph g = Example("scissors.yaml");
  const SymmetricReadings symmetries(g);
  REQUIRE(symmetries.any());
  const std::vector<Reading> readings = symmetries.Find(g.nominal, 1e-6, 16);
  // The mirror-image blades, each turned over onto the other's place: the screw's axis turns
  // with them and its 2 mm offset changes side, so every constraint still holds.
  REQUIRE(readings.size() == 1);
  const Reading& r = readings[0];
  CHECK(r.violation < 1e-6);
  CHECK(r.source_component[g.FindComponent("blade_a")] == g.FindComponent("blade_b"));
  CHECK(r.source_component[g.FindComponent("blade_b")] == g.FindComponent("blade_a"));
  CHECK(LargestPointMove(g, g.nominal, r) < 1e-9);
  // The blade's frame turned over: a different answer from the same points.
  const int a = g.blocks[g.components[g.FindComponent("blade_a")].block].index;
  CHECK(r.mean.poses[a].rotation.angularDistance(g.nominal.poses[a].rotation) > 3.0);
}

TEST_CASE("symmetric readings: a Stewart platform turned by a third", "[interp]") {
  const ConstraintGraph g = Example("stewart-platform.yaml");
  const SymmetricReadings symmetries(g);
  // Tolerance of the model file's rounding (coordinates to 0.1 mm).
  const std::vector<Reading> readings = symmetries.Find(g.nominal, 1e-3, 64);
  // Base and top turned together by a third either way, or turned over about one of the three
  // axes between anchor pairs: 5 readings besides the configuration itself. A plate turned
  // alone would stretch its legs by more than their range, and is not a reading.
  CHECK(readings.size() == 5);
  for (const Reading& r : readings) {
    CHECK(r.violation < 1e-3);
    CHECK(LargestPointMove(g, g.nominal, r) < 2e-4);
  }
}

TEST_CASE("symmetric readings: none for a model without symmetry, or a limit on the count",
          "[interp]") {
  const ConstraintGraph lamp = Example("lamp.yaml");
  const SymmetricReadings lamp_symmetries(lamp);
  CHECK(lamp_symmetries.Find(lamp.nominal, 0.1, 16).empty());
  // A flat link turned over about its spine puts its points back in place, but reverses its
  // joints' axes, where a revolute joint's residual vanishes too: no configuration.
  const ConstraintGraph arm = Example("planar-arm.yaml");
  const SymmetricReadings arm_symmetries(arm);
  CHECK(arm_symmetries.any());
  CHECK(arm_symmetries.Find(arm.nominal, 0.02, 16).empty());
  const ConstraintGraph g = Example("stewart-platform.yaml");
  CHECK(SymmetricReadings(g).Find(g.nominal, 1e-3, 2).size() == 2);
  CHECK(SymmetricReadings(g).Find(g.nominal, 1e-3, 0).empty());
}

TEST_CASE("symmetric readings: a folding ruler is not read from its other end", "[interp]") {
  const ConstraintGraph g = Example("folding-ruler.yaml");
  const SymmetricReadings symmetries(g);
  // Its segments are congruent, but read from the other end every fold turns the other way,
  // out of its limits of [0, 180] degrees.
  CHECK(symmetries.any());
  CHECK(symmetries.Find(g.nominal, 0.02, 16).empty());
  const std::vector<Reading> loose = symmetries.Find(g.nominal, 10, 16);
  REQUIRE(loose.size() == 16);
  for (const Reading& r : loose) {
    CHECK(r.violation > 0.1);
    CHECK(LargestPointMove(g, g.nominal, r) < 1e-6);
  }
}

}  // namespace
}  // namespace cfuse
