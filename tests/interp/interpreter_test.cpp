// The interpretation's search state (interp/src/interpreter.cpp), driven through its internal
// header: the measurement factors and noise summaries it is built on, repeated measurements
// taken once, the plan cache's owner checked, the unseeded search where P3P cannot seed, and
// the branch the node budget leaves as the answer.
#include "interpreter.h"

#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/evaluate.h"
#include "test_util.h"

namespace cfuse {
namespace {

using internal::Interpreter;
using internal::ModelPointRef;

MeasuredPoint Point3(const Eigen::Vector3d& xyz, const Eigen::Matrix3d& cov) {
  MeasuredPoint m;
  m.xyz = xyz;
  m.cov3 = cov;
  return m;
}

// The residual of `f` at `values`.
Eigen::VectorXd Residual(const ConstraintGraph& g, const Factor& f, const Values& values) {
  Eigen::VectorXd r;
  EvaluateResidual(*f.residual, g.blocks, f.blocks, values, &r, nullptr);
  return r;
}

TEST_CASE("interpreter: the largest variance, and the typical noise of 3D measurements",
          "[interp]") {
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Matrix3d cov = turn * Eigen::Vector3d(1, 9, 4).asDiagonal() * turn.transpose();
  CHECK(internal::LargestVariance(cov) == Approx(9));
  MeasurementSet set;
  CHECK(internal::TypicalNoise(set) == 0);
  MeasuredPoint image;
  image.is_3d = false;
  image.cov2 = 100 * Eigen::Matrix2d::Identity();
  set.points.push_back(image);
  CHECK(internal::TypicalNoise(set) == 0);  // image points have no 3D noise
  // Largest sigmas 3, 1 and 2 mm (the first anisotropic): the median is 2 mm.
  set.points.push_back(Point3(Eigen::Vector3d::Zero(), 1e-6 * cov));
  set.points.push_back(Point3(Eigen::Vector3d::Zero(), 1e-6 * Eigen::Matrix3d::Identity()));
  set.points.push_back(Point3(Eigen::Vector3d::Zero(), 4e-6 * Eigen::Matrix3d::Identity()));
  CHECK(internal::TypicalNoise(set) == Approx(0.002));
}

TEST_CASE("interpreter: a measurement's factor is its point's place, or its projection, less it",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const int lid = g.FindComponent("lid");
  const ModelPointRef corner{lid, 2};
  const Eigen::Vector3d at = ModelPoint(g, g.nominal, lid, 2);
  CHECK(internal::NominalWorld(g, corner) == at);
  MeasurementSet set;
  set.points.push_back(
      Point3(at + Eigen::Vector3d(0.01, -0.02, 0.03), 4e-6 * Eigen::Matrix3d::Identity()));
  const Factor f = internal::MeasurementFactor(g, set, corner, 0, false);
  CHECK(f.blocks == std::vector<int>{g.components[lid].block});
  CHECK(f.noise == set.points[0].cov3);
  CHECK(f.name == "measurement 0 of lid.l110");
  CHECK((Residual(g, f, g.nominal) - Eigen::Vector3d(-0.01, 0.02, -0.03)).norm() < 1e-15);
  // A prediction's factor: measured at zero, without noise.
  const Factor predicted = internal::MeasurementFactor(g, set, corner, -1, false);
  CHECK(predicted.noise.size() == 0);
  CHECK((Residual(g, predicted, g.nominal) - at).norm() < 1e-15);
  // In an image: the projection less the measured pixel.
  Values seen = g.nominal;
  for (Rigid3d& pose : seen.poses) pose.translation += Eigen::Vector3d(0, 0, 1.5);
  set.camera = testing::Pinhole();
  MeasuredPoint pixel;
  pixel.is_3d = false;
  pixel.uv = Eigen::Vector2d(300, 200);
  pixel.cov2 = Eigen::Matrix2d::Identity();
  set.points.push_back(pixel);
  const Factor image = internal::MeasurementFactor(g, set, corner, 1, true);
  const Eigen::Vector2d uv = set.camera->Project<double>(ModelPoint(g, seen, lid, 2));
  CHECK((Residual(g, image, seen) - (uv - pixel.uv)).norm() < 1e-9);
  CHECK(image.noise == pixel.cov2);
}

TEST_CASE("interpreter: a repeated measurement is one observation, matched in its first copy",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("tests/data/models/right-triangle.yaml"));
  SimulateOptions so;
  so.seed = 2;
  so.clutter = 0.5;
  const Simulation sim = Simulate(g, so);
  MeasurementSet twice = sim.measurements;
  const size_t n = twice.points.size();
  for (size_t i = 0; i < n; ++i) twice.points.push_back(twice.points[i]);
  const InterpretOptions options;
  const std::vector<bool> use(g.constraints.size(), true);
  Interpreter once(g, sim.measurements, options, use), repeated(g, twice, options, use);
  once.Run();
  repeated.Run();
  REQUIRE(repeated.complete_);
  CHECK(repeated.best_matched_ == 4);
  // The copies add no seed (each triple would have come 8 ways) and no branch.
  CHECK(repeated.stats_.seeds == once.stats_.seeds);
  CHECK(repeated.stats_.nodes == once.stats_.nodes);
  CHECK(repeated.best_assignment_ == once.best_assignment_);
  const FusionPlan& plan = repeated.best_plan();
  for (size_t l = 0; l < plan.levels.size(); ++l) {
    const int m = repeated.best_assignment_[l];
    REQUIRE(m >= 0);
    CHECK(m < static_cast<int>(n));  // never the later copy
    CHECK(sim.matches[m] == ModelPointName(g, plan.levels[l].component, plan.levels[l].feature));
  }
}

TEST_CASE("interpreter: a plan cache of another model is a broken contract", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("tests/data/models/right-triangle.yaml"));
  const ConstraintGraph other = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  const PlanCache cache(other);
  InterpretOptions options;
  options.plans = &cache;
  SimulateOptions so;
  const MeasurementSet set = Simulate(g, so).measurements;
  const std::vector<bool> use(g.constraints.size(), true);
  CHECK_THROWS_AS(Interpreter(g, set, options, use), InternalError);
  CHECK_THROWS_WITH(Interpret(g, set, options), Catch::Contains("a plan cache of another model"));
  // Its own model's cache is taken, and keeps the plan for the next interpretation.
  const PlanCache own(g);
  options.plans = &own;
  const Interpretation first = Interpret(g, set, options);
  int made = 0;
  own.Plan(false, nullptr, [&] {
    ++made;
    return FusionPlan{};
  });
  CHECK(made == 0);
  CHECK(first.matched == 4);
}

TEST_CASE("interpreter: without a pinhole camera to seed it, image data are searched unseeded",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera orthographic;
  orthographic.model = Camera::Model::kOrthographic;
  orthographic.scale = 1000;
  orthographic.cx = 320;
  orthographic.cy = 240;
  orthographic.width = 640;
  orthographic.height = 480;
  SimulateOptions so;
  so.camera = orthographic;
  InterpretOptions options;
  options.max_nodes = 2000;
  const std::vector<bool> use(g.constraints.size(), true);
  const MeasurementSet seen = Simulate(g, so).measurements;
  Interpreter unseeded(g, seen, options, use);
  CHECK(unseeded.image());
  unseeded.Run();
  CHECK(unseeded.stats_.seeds == 0);
  CHECK(unseeded.stats_.seeds_tried == 0);
  CHECK(unseeded.stats_.nodes > 0);
  // The same object through a pinhole camera is seeded by P3P.
  so.camera = testing::Pinhole();
  const MeasurementSet pinhole = Simulate(g, so).measurements;
  Interpreter seeded(g, pinhole, options, use);
  seeded.Run();
  CHECK(seeded.stats_.seeds > 0);
  CHECK(seeded.stats_.seeds_tried > 0);
}

TEST_CASE("interpreter: a search the budget ends answers with its best branch, unverified",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  SimulateOptions so;
  so.seed = 5;
  so.clutter = 2;
  const MeasurementSet set = Simulate(g, so).measurements;
  InterpretOptions options;
  options.max_nodes = 12;
  Interpreter search(g, set, options, std::vector<bool>(g.constraints.size(), true));
  search.Run();
  CHECK(search.stats_.status == SearchStats::Status::kBudget);
  CHECK_FALSE(search.complete_);
  REQUIRE(search.best_matched_ > 0);
  const auto matched = std::count_if(search.best_assignment_.begin(), search.best_assignment_.end(),
                                     [](int m) { return m >= 0; });
  CHECK(matched == search.best_matched_);
  CHECK(search.best_predicted_ == -1);
  REQUIRE(search.best_trace_.size() == search.best_plan().levels.size());
  for (const auto& level : search.best_trace_) CHECK(level.empty());
}

}  // namespace
}  // namespace cfuse
