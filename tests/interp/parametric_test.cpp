// Lowe's parametric estimator (cfuse/interp/parametric.h): its Jacobians against finite
// differences, exact recovery from noise-free data, consistency with its covariance (NEES), limits,
// the models it refuses, and agreement with constraint fusion on the same data.
#include "cfuse/interp/parametric.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <random>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/evaluate.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

// Every joint type with its own parameters: a floating root, a spherical wrist, a planar
// slider, a revolute pair with a mimic, a prismatic joint with limits, a fixed tool; three or
// more points on every component.
constexpr const char* kEveryJoint = R"(
name: every joint
units: {length: mm, angle: deg}
components:
  base: {points: {b1: [0, 0, 0], b2: [100, 0, 0], b3: [0, 80, 0], b4: [0, 0, 60]}}
  arm: {points: {a1: [0, 0, 0], a2: [150, 0, 10], a3: [0, 40, 20]}}
  twin: {points: {t1: [0, 0, 0], t2: [90, 20, 0], t3: [10, 50, 30]}}
  ball: {points: {s1: [40, 0, 0], s2: [0, 60, 0], s3: [20, 10, 70]}}
  sled: {points: {p1: [0, 0, 0], p2: [80, 0, 0], p3: [0, 70, 0], p4: [10, 10, 50]}}
  rod: {points: {r1: [0, 0, 0], r2: [120, 0, 0], r3: [0, 30, 30]}}
  tool: {points: {x1: [0, 0, 20], x2: [30, 0, 0], x3: [0, 25, 0]}}
  drone: {points: {d1: [0, 0, 0], d2: [50, 0, 0], d3: [0, 50, 0]}}
joints:
  shoulder: {type: revolute, parent: base, child: arm, origin: {xyz: [0, 0, 60]}, axis: [0, 0, 1],
             limits: [-120, 120], position: 20}
  mirror: {type: revolute, parent: base, child: twin, origin: {xyz: [100, 0, 0]},
           axis: [0, 1, 0], limits: [-90, 90], mimic: {joint: shoulder, multiplier: -0.5, offset: 10}}
  wrist: {type: spherical, parent: arm, child: ball, origin: {xyz: [150, 0, 10]}}
  table: {type: planar, parent: base, child: sled, origin: {xyz: [0, 80, 0]}, axis: [0, 0, 1]}
  extend: {type: prismatic, parent: sled, child: rod, origin: {xyz: [80, 0, 0]}, axis: [1, 0, 0],
           limits: [0, 100], position: 30}
  mount: {type: fixed, parent: rod, child: tool, origin: {xyz: [120, 0, 0]}}
  free: {type: floating, parent: base, child: drone, origin: {xyz: [0, 0, 200]}}
)";

ConstraintGraph LoadText(const std::string& text, const std::string& name) {
  const fs::path path = fs::temp_directory_path() / "cfuse_parametric_test" / name;
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
  return LoadModel(path.string());
}

// Labelled 3D measurements of every model point at `truth`, with noise `sigma`.
MeasurementSet Measure(const ConstraintGraph& g, unsigned seed, double sigma,
                       Values* truth = nullptr, bool sample_joints = true) {
  SimulateOptions so;
  so.seed = seed;
  so.noise = sigma;
  so.labels = true;
  so.sample_joints = sample_joints;
  const Simulation sim = Simulate(g, so);
  if (truth) *truth = sim.truth;
  return sim.measurements;
}

TEST_CASE("parametric: measurement and pose Jacobians match central differences") {
  const ConstraintGraph g = LoadText(kEveryJoint, "every.yaml");
  REQUIRE(ParametricUnsupported(g).empty());
  for (const bool image : {false, true}) {
    for (unsigned seed : {1u, 2u, 3u}) {
      INFO("seed " << seed << (image ? ", image points" : ", 3D points"));
      SimulateOptions so;
      so.seed = seed;
      so.labels = true;
      so.sample_joints = true;
      if (image) so.camera = testing::Pinhole();
      const Simulation sim = Simulate(g, so);
      // 6 (base) + 1 (shoulder) + 3 (wrist) + 3 (table) + 1 (extend) + 6 (free); mirror mimics.
      const int n = 20;
      // Simulation leaves the ball, planar and floating joints at their nominal motion: move
      // every parameter at random first.
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> u(-0.3, 0.3);
      const Eigen::VectorXd d0 = Eigen::VectorXd::NullaryExpr(n, [&] { return u(rng); });
      const Values moved = EvaluateParametric(g, sim.measurements, sim.truth, d0).values;
      const ParametricEvaluation at =
          EvaluateParametric(g, sim.measurements, moved, Eigen::VectorXd::Zero(n));
      REQUIRE(at.jacobian.cols() == n);
      const double h = 1e-6;
      Eigen::MatrixXd numeric(at.jacobian.rows(), n), numeric_pose(at.pose_jacobian.rows(), n);
      for (int i = 0; i < n; ++i) {
        const Eigen::VectorXd e = Eigen::VectorXd::Unit(n, i) * h;
        const ParametricEvaluation plus = EvaluateParametric(g, sim.measurements, moved, e);
        const ParametricEvaluation minus = EvaluateParametric(g, sim.measurements, moved, -e);
        numeric.col(i) = (plus.residual - minus.residual) / (2 * h);
        numeric_pose.col(i) = (LocalCoordinates(g.blocks, at.values, plus.values) -
                               LocalCoordinates(g.blocks, at.values, minus.values)) /
                              (2 * h);
      }
      CHECK((numeric - at.jacobian).cwiseAbs().maxCoeff() <=
            1e-6 * (1 + at.jacobian.cwiseAbs().maxCoeff()));
      for (const Block& b : g.blocks) {  // slacks follow their constraints: not parameters
        if (b.kind != BlockKind::kPose) continue;
        CHECK((numeric_pose - at.pose_jacobian)
                  .middleRows<6>(b.tangent_offset)
                  .cwiseAbs()
                  .maxCoeff() <= 1e-6);
      }
      // The configuration meets every joint, limit and mimic exactly.
      for (const Constraint& c : g.constraints) {
        Eigen::VectorXd r;
        EvaluateResidual(*c.residual, g.blocks, c.blocks, at.values, &r, nullptr);
        CHECK(r.lpNorm<Eigen::Infinity>() < 1e-10);
      }
    }
  }
}

TEST_CASE("parametric: noise-free measurements give the truth") {
  const ConstraintGraph g = LoadText(kEveryJoint, "every.yaml");
  for (unsigned seed : {4u, 5u, 6u}) {
    Values truth;
    MeasurementSet set = Measure(g, seed, 0.002, &truth);
    for (MeasuredPoint& p : set.points) {  // the truth itself, with the stated noise
      const ResolvedLabel l = ResolveLabels(g, MeasurementSet{set.source, {}, {p}})[0];
      p.xyz = ModelPoint(g, truth, l.component, l.feature);
    }
    const ParametricSolution s = SolveParametric(g, set);
    INFO("seed " << seed << ": " << s.iterations << " iterations");
    CHECK(s.converged);
    const Eigen::VectorXd error = LocalCoordinates(g.blocks, truth, s.solution.state.mean);
    // The vague prior about the start pulls by about (σ_data / σ_prior)² of the start's error.
    CHECK(error.lpNorm<Eigen::Infinity>() < 1e-6);
    CHECK(s.residual_variance < 1e-6);
    CHECK(s.solution.summary.max_constraint_residual < 1e-10);
  }
}

// The independent joints' errors against their covariance, summed over trials.
struct Consistency {
  double nees = 0;
  int dof = 0, converged = 0, trials = 0, outside_limits = 0;
  double residual_variance = 0;
};

Consistency Check(const ConstraintGraph& g, int trials, unsigned first_seed) {
  Consistency out;
  for (int t = 0; t < trials; ++t) {
    Values truth;
    const MeasurementSet set = Measure(g, first_seed + t, 0.002, &truth);
    const ParametricSolution s = SolveParametric(g, set);
    ++out.trials;
    out.converged += s.converged ? 1 : 0;
    out.residual_variance += s.residual_variance / trials;
    const JointEstimates estimate = EstimateJoints(g, s.solution.state, true);
    Eigen::VectorXd e = estimate.values - JointValues(g, truth, true);
    for (int i = 0; i < e.size(); ++i) {
      const Joint& j = g.joints[estimate.joints[i]];
      if (j.type != JointType::kPrismatic) e[i] = std::remainder(e[i], 2 * M_PI);
      if (j.limits && (estimate.values[i] < j.limits->first - 1e-12 ||
                       estimate.values[i] > j.limits->second + 1e-12)) {
        ++out.outside_limits;
      }
    }
    out.nees += e.dot(estimate.covariance.ldlt().solve(e));
    out.dof += static_cast<int>(e.size());
  }
  return out;
}

TEST_CASE("parametric: joint errors are consistent with the reported covariance (NEES)") {
  const ConstraintGraph g = LoadText(kEveryJoint, "every.yaml");
  const Consistency c = Check(g, 100, 700);
  const double lo = ChiSquareQuantile(0.005, c.dof), hi = ChiSquareQuantile(0.995, c.dof);
  INFO("NEES " << c.nees << " over " << c.dof << " DOF, 99 % interval [" << lo << ", " << hi
               << "]; residual variance " << c.residual_variance);
  CHECK(c.converged == c.trials);
  CHECK(c.nees >= lo);
  CHECK(c.nees <= hi);
  CHECK(c.outside_limits == 0);
  // Lowe's residual test: the whitened residual's variance is about 1 for right matches.
  CHECK(c.residual_variance == Approx(1.0).margin(0.1));
}

TEST_CASE("parametric: a truth on its limit is held there, never passed") {
  const ConstraintGraph g = LoadText(kEveryJoint, "every.yaml");
  const int extend = g.FindJoint("extend");
  int on_limit = 0, trials = 40;
  for (int t = 0; t < trials; ++t) {
    // The prismatic joint fully retracted (its lower limit, 0).
    std::vector<JointValue> given = {{"shoulder", 0.3, {}}, {"extend", 0.0, {}}};
    Values truth = ForwardKinematics(g, CompleteJointValues(g, given));
    SimulateOptions so;
    so.seed = 900 + t;
    so.labels = true;
    so.sample_joints = true;
    MeasurementSet set = Simulate(g, so).measurements;
    std::mt19937 rng(900 + t);
    std::normal_distribution<double> noise(0, 0.002);
    for (MeasuredPoint& p : set.points) {
      const ResolvedLabel l = ResolveLabels(g, MeasurementSet{set.source, {}, {p}})[0];
      p.xyz = ModelPoint(g, truth, l.component, l.feature) +
              Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
    const ParametricSolution s = SolveParametric(g, set);
    REQUIRE(s.converged);
    const JointEstimates q = EstimateJoints(g, s.solution.state);
    const auto it = std::find(q.joints.begin(), q.joints.end(), extend);
    const double value = q.values[it - q.joints.begin()];
    CHECK(value >= -1e-12);
    if (value < 1e-9) ++on_limit;
  }
  // About half the estimates would pass the limit if free: those sit on it.
  INFO(on_limit << " of " << trials << " on the limit");
  CHECK(on_limit >= 10);
  CHECK(on_limit <= 30);
}

TEST_CASE("parametric: agrees with constraint fusion on the same data") {
  const ConstraintGraph g = LoadText(kEveryJoint, "every.yaml");
  for (unsigned seed : {11u, 12u, 13u, 14u, 15u}) {
    Values truth;
    const MeasurementSet set = Measure(g, seed, 0.002, &truth);
    const ParametricSolution p = SolveParametric(g, set);
    const Solution f = Solve(g, set);
    REQUIRE(p.converged);
    REQUIRE(f.summary.converged);
    const JointEstimates qp = EstimateJoints(g, p.solution.state, true);
    const JointEstimates qf = EstimateJoints(g, f.state, true);
    for (int i = 0; i < qp.values.size(); ++i) {
      const double sigma = std::sqrt(qf.covariance(i, i));
      INFO("seed " << seed << ", joint " << g.joints[qp.joints[i]].name);
      // The two differ only by their vague priors (on different coordinates).
      CHECK(std::abs(qp.values[i] - qf.values[i]) < 0.01 * sigma);
      CHECK(std::sqrt(qp.covariance(i, i)) == Approx(sigma).epsilon(0.01));
    }
  }
}

TEST_CASE("parametric: models without a parametric form are refused by name") {
  const ConstraintGraph lamp = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  CHECK_THAT(ParametricUnsupported(lamp), Catch::Matchers::Contains("is a single point"));
  const ConstraintGraph scissors = LoadModel(testing::SourcePath("examples/scissors.yaml"));
  CHECK_THAT(ParametricUnsupported(scissors), Catch::Matchers::Contains("constraint 'opening'") &&
                                                  Catch::Matchers::Contains("is not a joint"));
  const ConstraintGraph loop = LoadText(R"(
name: loop
components:
  a: {points: {a1: [0, 0, 0], a2: [1, 0, 0], a3: [0, 1, 0]}}
  b: {points: {b1: [0, 0, 0], b2: [1, 0, 0], b3: [0, 1, 0]}}
  c: {points: {c1: [0, 0, 0], c2: [1, 0, 0], c3: [0, 1, 0]}}
joints:
  ab: {type: revolute, parent: a, child: b, axis: [0, 0, 1]}
  bc: {type: revolute, parent: b, child: c, axis: [0, 0, 1]}
constraints:
  - {name: closure, expr: "distance(c1, a2) == nominal"}
)",
                                        "loop.yaml");
  // The DSL closes a kinematic loop with a constraint (a joint may not close it).
  CHECK_THAT(ParametricUnsupported(loop), Catch::Matchers::Contains("constraint 'closure'"));
  const MeasurementSet none;
  try {
    SolveParametric(lamp, none);
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK_THAT(e.message(), Catch::Matchers::StartsWith("no parametric form for model"));
    CHECK(e.where().file == lamp.source);
  }
  // The planar arm's reach limit is a distance between points; the hinged box has a form.
  CHECK_THAT(ParametricUnsupported(LoadModel(testing::SourcePath("examples/planar-arm.yaml"))),
             Catch::Matchers::Contains("constraint 'reach' (distance <=)"));
  CHECK(ParametricUnsupported(LoadModel(testing::SourcePath("examples/hinged-box.yaml")))
            .empty());
}

}  // namespace
}  // namespace cfuse
