// Simulated data: a truth on the constraint surface, measurements with the stated noise, the
// clutter and occlusion asked for, joints inside their limits, the refusals, and the two ways a
// label is judged right (one model place, or within pixels in an image).
#include "cfuse/interp/simulate.h"

#include <algorithm>
#include <catch2/catch.hpp>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/schedule.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/chi_square.h"
#include "test_util.h"

namespace cfuse {
namespace {

// The place in `values` of the model point named `name` ("p3", "box.c000").
Eigen::Vector3d Named(const ConstraintGraph& g, const Values& values, const std::string& name) {
  for (size_t c = 0; c < g.components.size(); ++c) {
    const int n = g.components[c].rigid ? static_cast<int>(g.components[c].points.size()) : 1;
    for (int f = 0; f < n; ++f) {
      const int feature = g.components[c].rigid ? f : -1;
      if (ModelPointName(g, static_cast<int>(c), feature) == name) {
        return ModelPoint(g, values, static_cast<int>(c), feature);
      }
    }
  }
  FAIL("no model point " << name);
  return {};
}

// Whether `statistic` lies in the central 99.9 % of a chi-square with `dof` degrees of freedom.
bool ChiSquareLike(double statistic, int dof) {
  return statistic > ChiSquareQuantile(0.0005, dof) && statistic < ChiSquareQuantile(0.9995, dof);
}

TEST_CASE("simulate: the truth meets every constraint; measurements carry the stated noise",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  SimulateOptions so;
  so.seed = 11;
  so.labels = true;
  so.noise = 0.003;
  const Simulation sim = Simulate(g, so);
  Eigen::VectorXd r;
  EvaluateConstraints(g, sim.truth, &r, nullptr);
  CHECK(r.cwiseAbs().maxCoeff() < 1e-9);
  // Every point, in the model's order, labelled, the truth plus noise of 3 mm.
  REQUIRE(sim.measurements.points.size() == g.components.size());
  double chi2 = 0;
  for (size_t i = 0; i < sim.matches.size(); ++i) {
    const MeasuredPoint& m = sim.measurements.points[i];
    CHECK(sim.matches[i] == ModelPointName(g, static_cast<int>(i), -1));
    CHECK(m.label == sim.matches[i]);
    CHECK(m.is_3d);
    CHECK(m.cov3 == 9e-6 * Eigen::Matrix3d::Identity());
    chi2 += (m.xyz - Named(g, sim.truth, m.label)).squaredNorm() / 9e-6;
  }
  CHECK(ChiSquareLike(chi2, 3 * static_cast<int>(sim.matches.size())));
  // The configuration is the nominal one perturbed, not the nominal one moved: some distance no
  // constraint holds has changed.
  bool reshaped = false;
  for (size_t i = 0; i < g.components.size(); ++i) {
    for (size_t j = i + 1; j < g.components.size(); ++j) {
      const double now = (sim.truth.points[i] - sim.truth.points[j]).norm();
      const double before = (g.nominal.points[i] - g.nominal.points[j]).norm();
      reshaped = reshaped || std::abs(now - before) > 1e-3;
    }
  }
  CHECK(reshaped);
}

TEST_CASE("simulate: occlusion and clutter as asked, the clutter among the real points",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  SimulateOptions so;
  so.seed = 4;
  so.occlusion = 0.2;  // 23 points, 5 of them not measured
  so.clutter = 1.5;    // 27 clutter points for the 18 real ones
  const Simulation sim = Simulate(g, so);
  REQUIRE(sim.measurements.points.size() == 45);
  REQUIRE(sim.matches.size() == 45);
  const auto clutter = std::count(sim.matches.begin(), sim.matches.end(), "");
  CHECK(clutter == 27);
  Eigen::AlignedBox3d real;
  std::vector<std::string> seen;
  for (const std::string& name : sim.matches) {
    if (name.empty()) continue;
    real.extend(Named(g, sim.truth, name));
    CHECK(std::find(seen.begin(), seen.end(), name) == seen.end());  // each point once
    seen.push_back(name);
  }
  bool shuffled = false;
  for (size_t i = 0; i < sim.matches.size(); ++i) {
    const MeasuredPoint& m = sim.measurements.points[i];
    CHECK(m.label.empty());  // labels are the interpretation's to find
    if (sim.matches[i].empty()) CHECK(real.contains(m.xyz));
    shuffled = shuffled || (i > 0 && sim.matches[i].empty() != sim.matches[i - 1].empty());
  }
  CHECK(shuffled);  // clutter among the real points, not after them
}

TEST_CASE("simulate: a seed gives one simulation", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  SimulateOptions so;
  so.seed = 9;
  so.clutter = 0.5;
  const Simulation a = Simulate(g, so), b = Simulate(g, so);
  so.seed = 10;
  const Simulation c = Simulate(g, so);
  REQUIRE(a.measurements.points.size() == b.measurements.points.size());
  for (size_t i = 0; i < a.measurements.points.size(); ++i) {
    CHECK(a.measurements.points[i].xyz == b.measurements.points[i].xyz);
  }
  CHECK(a.matches == b.matches);
  CHECK(a.measurements.points[0].xyz != c.measurements.points[0].xyz);
}

TEST_CASE("simulate: seen by a camera, every point inside the image with the stated noise",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const Camera camera = testing::Pinhole();
  SimulateOptions so;
  so.camera = camera;
  so.pixel_noise = 0.5;
  so.labels = true;
  double chi2 = 0;
  int n = 0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    so.seed = seed;
    const Simulation sim = Simulate(g, so);
    REQUIRE(sim.measurements.camera);
    for (const MeasuredPoint& m : sim.measurements.points) {
      CHECK_FALSE(m.is_3d);
      CHECK(m.cov2 == 0.25 * Eigen::Matrix2d::Identity());
      const Eigen::Vector3d p = Named(g, sim.truth, m.label);
      CHECK(p.z() > 0);
      const Eigen::Vector2d uv = camera.Project<double>(p);
      CHECK(uv.minCoeff() >= 0);
      CHECK(uv.x() <= camera.width - 1);
      CHECK(uv.y() <= camera.height - 1);
      chi2 += (m.uv - uv).squaredNorm() / 0.25;
      n += 2;
    }
  }
  CHECK(ChiSquareLike(chi2, n));
}

TEST_CASE("simulate: joints drawn inside the middle 80 % of their limits", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  SimulateOptions so;
  so.sample_joints = true;
  double lowest = 1e9, highest = -1e9;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    so.seed = seed;
    const double hinge = JointValues(g, Simulate(g, so).truth)[0] * 180 / M_PI;
    lowest = std::min(lowest, hinge);
    highest = std::max(highest, hinge);
  }
  // Limits [0, 120] degrees: drawn in [12, 108], and spread over it.
  CHECK(lowest >= 12 - 1e-6);
  CHECK(highest <= 108 + 1e-6);
  CHECK(highest - lowest > 50);
}

TEST_CASE("simulate: what cannot be simulated is refused at the model", "[interp]") {
  const std::string arm = testing::SourcePath("examples/planar-arm.yaml");
  const ConstraintGraph g = LoadModel(arm);
  // A model fixed in the world stays where it is, which the camera at the origin does not see.
  SimulateOptions so;
  const Simulation sim = Simulate(g, so);
  const int base = g.blocks[g.components[g.FindComponent("base")].block].index;
  CHECK((sim.truth.poses[base].translation - g.nominal.poses[base].translation).norm() < 1e-9);
  so.camera = testing::Pinhole();
  try {
    Simulate(g, so);
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().file == arm);
    CHECK_THAT(e.message(), Catch::StartsWith("cannot simulate: the model is fixed in the world"));
  }
  // An image too small for any pose.
  const ConstraintGraph box = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera tiny = testing::Pinhole();
  tiny.width = tiny.height = 1;
  so.camera = tiny;
  CHECK_THROWS_WITH(Simulate(box, so),
                    Catch::EndsWith("cannot simulate: no pose puts every model point inside the "
                                    "image"));
  // Constraints no configuration meets.
  const ConstraintGraph torn = LoadModelFromString(
      "name: torn\nunits: {length: mm}\npoints: {a: [0, 0, 0], b: [100, 0, 0]}\nconstraints:\n"
      "  - distance(a, b) == 100 mm\n  - distance(a, b) == 150 mm\n",
      "torn.yaml", ".");
  try {
    Simulate(torn, {});
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().file == "torn.yaml");
    CHECK(e.message() ==
          "cannot simulate: no configuration satisfying every constraint was found near the "
          "nominal geometry");
  }
}

TEST_CASE("simulate: a label is right at the true point's place, or near it in the image",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  SimulateOptions so;
  so.sample_joints = true;
  const Values truth = Simulate(g, so).truth;
  // The hinge joins the box's back top corners and the lid's: one place, whatever the angle.
  CHECK(SameModelPlace(g, truth, "box.c011", "lid.l010"));
  CHECK(SameModelPlace(g, truth, "box.c111", "lid.l110"));
  CHECK_FALSE(SameModelPlace(g, truth, "box.c000", "box.c100"));
  CHECK(SameModelPlace(g, truth, "", ""));  // clutter left unmatched
  CHECK_FALSE(SameModelPlace(g, truth, "", "box.c000"));
  CHECK_FALSE(SameModelPlace(g, truth, "box.c000", ""));
  CHECK_FALSE(SameModelPlace(g, truth, "box.c000", "box.nowhere"));

  Values seen = g.nominal;
  for (Rigid3d& pose : seen.poses) pose.translation += Eigen::Vector3d(-0.1, -0.1, 1.5);
  const Camera camera = testing::Pinhole();
  const std::optional<double> apart = ImageSeparation(g, seen, camera, "box.c000", "box.c100");
  REQUIRE(apart);
  // c000 and c100 lie 300 mm apart along x at one depth, 1.5 m: 800 px/m x 0.3 m / 1.5.
  CHECK(*apart == Approx(160).epsilon(1e-12));
  CHECK(*ImageSeparation(g, seen, camera, "box.c011", "lid.l010") == Approx(0).margin(1e-9));
  CHECK_FALSE(ImageSeparation(g, seen, camera, "", "box.c000"));
  CHECK_FALSE(ImageSeparation(g, seen, camera, "box.c000", "box.nowhere"));
}

}  // namespace
}  // namespace cfuse
