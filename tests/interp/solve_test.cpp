// Solving with known correspondences: orientation independence, constraints met, occluded
// points through constraints, rigid components from image points alone.
#include "cfuse/interp/solve.h"

#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>
#include <limits>
#include <random>

#include "cfuse/constraints/dof.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/evaluate.h"
#include "test_util.h"

namespace cfuse {
namespace {

Rigid3d RandomPose(std::mt19937& rng, double depth) {
  std::normal_distribution<double> n(0, 1);
  return Rigid3d(Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(),
                 Eigen::Vector3d(0.1 * n(rng), 0.1 * n(rng), depth));
}

// Every model point of the graph at `truth`, measured in 3D with isotropic noise.
MeasurementSet Measure3d(const ConstraintGraph& g, const Values& truth, std::mt19937& rng,
                         double sigma, const std::string& skip = "") {
  std::normal_distribution<double> n(0, sigma);
  MeasurementSet set;
  for (size_t c = 0; c < g.components.size(); ++c) {
    const Component& comp = g.components[c];
    const int count = comp.rigid ? static_cast<int>(comp.points.size()) : 1;
    for (int f = 0; f < count; ++f) {
      const std::string label = comp.rigid ? comp.name + "." + comp.points[f].name : comp.name;
      if (label == skip) continue;
      MeasuredPoint m;
      m.xyz = ModelPoint(g, truth, static_cast<int>(c), comp.rigid ? f : -1) +
              Eigen::Vector3d(n(rng), n(rng), n(rng));
      m.cov3 = sigma * sigma * Eigen::Matrix3d::Identity();
      m.label = label;
      set.points.push_back(m);
    }
  }
  return set;
}

// Every feature point of the rigid components at `truth`, seen by `camera` with pixel noise.
MeasurementSet MeasureImage(const ConstraintGraph& g, const Values& truth, const Camera& camera,
                            std::normal_distribution<double>& pixel, std::mt19937& rng) {
  MeasurementSet set;
  set.camera = camera;
  for (size_t c = 0; c < g.components.size(); ++c) {
    for (size_t f = 0; f < g.components[c].points.size(); ++f) {
      MeasuredPoint m;
      m.is_3d = false;
      m.uv =
          camera.Project<double>(ModelPoint(g, truth, static_cast<int>(c), static_cast<int>(f))) +
          Eigen::Vector2d(pixel(rng), pixel(rng));
      m.cov2 = pixel.stddev() * pixel.stddev() * Eigen::Matrix2d::Identity();
      m.label = g.components[c].name + "." + g.components[c].points[f].name;
      set.points.push_back(m);
    }
  }
  return set;
}

Values Moved(const ConstraintGraph& g, const Rigid3d& pose) {
  Values v = g.nominal;
  for (Rigid3d& p : v.poses) p = pose * p;
  for (Eigen::Vector3d& p : v.points) p = pose * p;
  return v;
}

TEST_CASE("solve: the lamp at poses all over SO(3): constraints met, error at noise level",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  for (unsigned seed = 1; seed <= 40; ++seed) {
    std::mt19937 rng(seed);
    const Values truth = Moved(g, RandomPose(rng, 1.5));
    const Solution s = Solve(g, Measure3d(g, truth, rng, 0.002));
    INFO("seed " << seed);
    REQUIRE(s.summary.converged);
    CHECK(s.contradictions.empty());
    CHECK(s.summary.max_constraint_residual <= 1e-8 * s.extent);
    double worst = 0;
    for (size_t i = 0; i < truth.points.size(); ++i) {
      worst = std::max(worst, (s.state.mean.points[i] - truth.points[i]).norm());
    }
    CHECK(worst < 5 * 0.002 * std::sqrt(3.0));
  }
}

TEST_CASE("solve: an occluded point is estimated through the constraints, less certainly",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  std::mt19937 rng(3);
  const Values truth = Moved(g, RandomPose(rng, 1.5));
  std::mt19937 rng_a(4), rng_b(4);
  const Solution all = Solve(g, Measure3d(g, truth, rng_a, 0.002));
  const Solution occluded = Solve(g, Measure3d(g, truth, rng_b, 0.002, "p23"));
  REQUIRE(occluded.summary.converged);
  const int i = g.blocks[g.components[g.FindComponent("p23")].block].index;
  const int o = g.blocks[g.components[g.FindComponent("p23")].block].tangent_offset;
  CHECK((occluded.state.mean.points[i] - truth.points[i]).norm() < 0.02);
  CHECK(occluded.state.covariance.block<3, 3>(o, o).trace() >
        all.state.covariance.block<3, 3>(o, o).trace());
}

// A fifth of the lamp's points unmeasured, hubs among them (the turret top, the elbow's side,
// the wrist): started where the rigid guess puts them, their constraints threw the sequential
// pass far off; placed first where their constraints to known points hold best, it converges.
TEST_CASE("solve: a lamp with a fifth of its points occluded converges from no guess", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  int converged = 0;
  const int trials = 20;
  for (int i = 0; i < trials; ++i) {
    SimulateOptions so;
    so.seed = i;
    so.occlusion = 0.2;
    so.labels = true;
    const Simulation sim = Simulate(g, so);
    const Solution s = Solve(g, sim.measurements);
    converged += s.summary.converged ? 1 : 0;
  }
  CHECK(converged == trials);
}

TEST_CASE("solve: the hinged box from image points alone (§7), poses all over SO(3)", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera camera = testing::Pinhole();
  camera.distortion[0] = -0.05;
  SolveOptions options;
  int solved = 0;
  for (unsigned seed = 1; seed <= 30; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> pixel(0, 0.5);
    const Values truth = Moved(g, RandomPose(rng, 1.6));
    const MeasurementSet set = MeasureImage(g, truth, camera, pixel, rng);
    const Solution s = Solve(g, set, options);
    INFO("seed " << seed);
    CHECK(s.summary.converged);
    const Rigid3d& box = s.state.mean.poses[0];
    const Rigid3d& box_truth = truth.poses[0];
    const double rotation_error = box.rotation.angularDistance(box_truth.rotation);
    const double translation_error = (box.translation - box_truth.translation).norm();
    CHECK(rotation_error < 0.02);
    CHECK(translation_error < 0.02);
    solved += rotation_error < 0.02 && translation_error < 0.02;
  }
  CHECK(solved == 30);
}

TEST_CASE("solve: the hinged box from an orthographic view alone, poses all over SO(3)",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera camera;
  camera.model = Camera::Model::kOrthographic;
  camera.scale = 1000;  // pixels per metre
  camera.cx = 320;
  camera.cy = 240;
  int solved = 0;
  for (unsigned seed = 1; seed <= 30; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> pixel(0, 0.5);
    const Values truth = Moved(g, RandomPose(rng, 1.6));
    const MeasurementSet set = MeasureImage(g, truth, camera, pixel, rng);
    const Solution s = Solve(g, set);  // no PnP solver: the orthographic start is built in
    INFO("seed " << seed);
    CHECK(s.summary.converged);
    const int o = g.blocks[g.components[0].block].tangent_offset;
    const Rigid3d& box = s.state.mean.poses[0];
    const Rigid3d& box_truth = truth.poses[0];
    const double rotation_error = box.rotation.angularDistance(box_truth.rotation);
    const double image_plane_error = (box.translation - box_truth.translation).head<2>().norm();
    CHECK(rotation_error < 0.02);
    CHECK(image_plane_error < 0.002);
    // Depth is not observed: its variance stays at the vague prior's.
    CHECK(std::sqrt(s.state.covariance(o + 5, o + 5)) > 1.0);
    solved += rotation_error < 0.02 && image_plane_error < 0.002;
  }
  CHECK(solved == 30);
}

TEST_CASE("solve: a supplied guess starts what no closed form can", "[interp]") {
  // The hinged box seen by a pinhole camera, with no PnP solver wired in: only a guess can
  // put it in front of the camera.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const Camera camera = testing::Pinhole();
  int solved = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> pixel(0, 0.5), n(0, 1);
    const Values truth = Moved(g, RandomPose(rng, 1.6));
    const MeasurementSet set = MeasureImage(g, truth, camera, pixel, rng);
    // The truth moved by about 0.1 rad and 5 cm.
    PoseSet guess;
    const Rigid3d error(Eigen::Quaterniond(Eigen::AngleAxisd(
                            0.1, Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized())),
                        Eigen::Vector3d(0.03, -0.03, 0.03));
    for (size_t c = 0; c < g.components.size(); ++c) {
      guess.components.push_back({g.components[c].name, error * truth.poses[c], {}});
    }
    SolveOptions options;
    options.guess = &guess;
    const Solution s = Solve(g, set, options);
    INFO("seed " << seed);
    CHECK(s.summary.converged);
    const double rotation_error =
        s.state.mean.poses[0].rotation.angularDistance(truth.poses[0].rotation);
    CHECK(rotation_error < 0.02);
    solved += s.summary.converged && rotation_error < 0.02;
  }
  CHECK(solved == 10);
}

// Two links on a revolute joint with limits [0, 60] deg, four points each. The tests below start
// far off (Gauss-Newton passes stay in one chart) and outside the limit (the active-set test
// releases it).
const char* const kElbow = R"(name: elbow
units: {length: mm, angle: deg}
components:
  upper:
    pose: {xyz: [0, 0, 0]}
    points: {a: [0, 0, 0], b: [300, 0, 0], c: [0, 60, 0], d: [150, 0, 50]}
  fore:
    points: {a: [0, 0, 0], b: [250, 0, 0], c: [0, 40, 0], d: [120, 0, -40]}
joints:
  elbow: {type: revolute, parent: upper, child: fore, origin: {xyz: [300, 0, 0]},
          axis: [0, 0, 1], limits: [0, 60], position: 30}
)";

// The elbow model at `angle` (rad), moved to `pose`.
Values ElbowAt(const ConstraintGraph& g, double angle, const Rigid3d& pose) {
  const Joint& j = g.joints[0];
  Values v = g.nominal;
  v.poses[0] = pose;
  v.poses[1] = pose * j.parent_from_joint * JointMotion(j.type, j.axis, angle);
  return v;
}

TEST_CASE("solve: a Gauss-Newton pass stays exact when the start is far off", "[interp]") {
  // Each link's start is 0.5 rad and 10 cm off: the passes still meet the joint to 1e-8 of
  // the model's size (moving the chart after each update stalled such starts at 1e-4).
  const ConstraintGraph g = LoadModelFromString(kElbow, "elbow.yaml", ".");
  for (unsigned seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0, 1);
    const Values truth = ElbowAt(g, 0.6, RandomPose(rng, 1.0));
    const MeasurementSet set = Measure3d(g, truth, rng, 0.001);
    PoseSet guess;
    for (size_t c = 0; c < 2; ++c) {
      const Rigid3d off(Eigen::Quaterniond(Eigen::AngleAxisd(
                            0.5, Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized())),
                        Eigen::Vector3d(0.1, -0.05, 0.05));
      guess.components.push_back({g.components[c].name, off * truth.poses[c], {}});
    }
    SolveOptions options;
    options.guess = &guess;
    const Solution s = Solve(g, set, options);
    PoseSet at_truth;
    for (size_t c = 0; c < 2; ++c) {
      at_truth.components.push_back({g.components[c].name, truth.poses[c], {}});
    }
    SolveOptions from_truth;
    from_truth.guess = &at_truth;
    const Solution t = Solve(g, set, from_truth);
    INFO("seed " << seed << ": " << s.summary.passes << " passes, constraints to "
                 << s.summary.max_constraint_residual);
    CHECK(s.summary.converged);
    CHECK(s.summary.max_constraint_residual <= 1e-8 * s.extent);
    // The same estimate as from the truth itself, within a few hundredths of its standard
    // deviation (about 3e-3 rad and 1 mm here; passes stop at a hundredth).
    REQUIRE(t.summary.converged);
    for (size_t c = 0; c < 2; ++c) {
      CHECK(s.state.mean.poses[c].rotation.angularDistance(t.state.mean.poses[c].rotation) < 1e-4);
      CHECK((s.state.mean.poses[c].translation - t.state.mean.poses[c].translation).norm() < 3e-5);
    }
  }
}

TEST_CASE("solve: a limit held at a start outside it lets go when the data pull inside",
          "[interp]") {
  // Truths inside [0, 60] deg, near the lower limit; starts outside it, where the limit's slack
  // is 0 and its linearisation an equality that would hold the joint at 0 for good without the
  // active-set test.
  const ConstraintGraph g = LoadModelFromString(kElbow, "elbow.yaml", ".");
  const Joint& j = g.joints[0];
  int right = 0, trials = 0;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    const double truth_angle = (2 + seed % 5) * M_PI / 180;
    const Values truth = ElbowAt(g, truth_angle, RandomPose(rng, 1.0));
    const MeasurementSet set = Measure3d(g, truth, rng, 0.0005);
    const Values start = ElbowAt(g, -(10.0 + seed) * M_PI / 180, truth.poses[0]);
    PoseSet guess;
    for (size_t c = 0; c < 2; ++c) {
      guess.components.push_back({g.components[c].name, start.poses[c], {}});
    }
    SolveOptions options;
    options.guess = &guess;
    const Solution s = Solve(g, set, options);
    const Rigid3d relative =
        (s.state.mean.poses[0] * j.parent_from_joint).Inverse() * s.state.mean.poses[1];
    const double angle = Eigen::AngleAxisd(relative.rotation).angle();
    INFO("seed " << seed << ": truth " << truth_angle << ", estimate " << angle);
    CHECK(s.summary.converged);
    CHECK(std::abs(angle - truth_angle) < 0.005);
    ++trials;
    right += std::abs(angle - truth_angle) < 0.005;
  }
  CHECK(right == trials);
}

TEST_CASE("solve: an estimate held on a limit does not claim the limit known to zero variance",
          "[interp]") {
  // Truths 1 degree beyond the lower limit: the estimate stays on the limit. Its joint angle's
  // variance is the data's, as without the limit, not the 0 of a boundary held as an equality
  // (the truth of a real object is then anywhere inside).
  const ConstraintGraph limited = LoadModelFromString(kElbow, "elbow.yaml", ".");
  std::string wide = kElbow;
  wide.replace(wide.find("limits: [0, 60]"), 15, "limits: [-60, 60]");
  const ConstraintGraph unlimited = LoadModelFromString(wide, "elbow.yaml", ".");
  for (unsigned seed = 1; seed <= 5; ++seed) {
    std::mt19937 rng(seed);
    const Values truth = ElbowAt(limited, -1 * M_PI / 180, RandomPose(rng, 1.0));
    const MeasurementSet set = Measure3d(limited, truth, rng, 0.002);
    const Solution on = Solve(limited, set);
    const Solution off = Solve(unlimited, set);
    REQUIRE(on.accepted());
    REQUIRE(off.accepted());
    const auto angle_variance = [](const ConstraintGraph& g, const Solution& s) {
      const Eigen::MatrixXd j = JointJacobian(g, s.state.mean);
      const int n = static_cast<int>(j.cols());
      return (j * s.state.covariance.topLeftCorner(n, n) * j.transpose())(0, 0);
    };
    REQUIRE(std::abs(JointValues(limited, on.state.mean)(0)) < 1e-6);  // on the limit
    const double held = angle_variance(limited, on), free = angle_variance(unlimited, off);
    INFO("seed " << seed << ": angle variance " << held << " on the limit, " << free
                 << " without it");
    CHECK(free > 0);
    CHECK(held > 0.5 * free);
    CHECK(held < 2 * free);
  }
}

}  // namespace
}  // namespace cfuse

namespace cfuse {
namespace {

// NEES over `trials` simulated configurations: the estimate's error against its covariance,
// on the covariance's range (its rank is the model's DOF). Returns the total and its DOF.
std::pair<double, int> TotalNees(const ConstraintGraph& g, int trials, bool all_ok_required,
                                 int* better_than_measurements) {
  double total = 0;
  int dof = 0;
  *better_than_measurements = 0;
  for (int trial = 0; trial < trials; ++trial) {
    SimulateOptions options;
    options.seed = 500 + trial;
    options.labels = true;
    const Simulation sim = Simulate(g, options);
    const Solution s = Solve(g, sim.measurements);
    INFO("trial " << trial << ": " << s.summary.passes << " passes, constraint residual "
                  << s.summary.max_constraint_residual << ", contradictions "
                  << s.contradictions.size());
    if (all_ok_required) REQUIRE(s.summary.converged);
    // The measured points: estimate against the raw measurements.
    double estimate_error = 0, measurement_error = 0;
    for (const ResolvedLabel& r : s.labels) {
      const Eigen::Vector3d truth = ModelPoint(g, sim.truth, r.component, r.feature);
      estimate_error += (ModelPoint(g, s.state.mean, r.component, r.feature) - truth).squaredNorm();
      measurement_error += (sim.measurements.points[r.measurement].xyz - truth).squaredNorm();
    }
    *better_than_measurements += estimate_error < measurement_error ? 1 : 0;
    // Slacks are not part of the error: compare the geometry blocks only.
    const Eigen::VectorXd e_full = LocalCoordinates(g.blocks, sim.truth, s.state.mean);
    std::vector<int> index;
    for (const Block& b : g.blocks) {
      if (b.kind == BlockKind::kSlack) continue;
      for (int i = 0; i < TangentDim(b.kind); ++i) index.push_back(b.tangent_offset + i);
    }
    const Eigen::VectorXd e = e_full(index);
    const Eigen::MatrixXd P = s.state.covariance(index, index);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(P);
    const Eigen::VectorXd& l = eigen.eigenvalues();
    for (int i = 0; i < l.size(); ++i) {
      if (l[i] <= 1e-9 * l.maxCoeff()) continue;
      const double proj = eigen.eigenvectors().col(i).dot(e);
      total += proj * proj / l[i];
      ++dof;
    }
  }
  return {total, dof};
}

// The 99% interval of a chi-square with k DOF (Wilson-Hilferty).
std::pair<double, double> ChiSquare99(double k) {
  const double z = 2.5758, a = 2 / (9 * k);
  return {k * std::pow(1 - a - z * std::sqrt(a), 3), k * std::pow(1 - a + z * std::sqrt(a), 3)};
}

// The batch paths (SolveOptions::sparse_from_dim; the joints eliminated below
// SolveOptions::reduced_below, the sparse solver above) on cabinets with both joints well
// inside their limits: the filter's answer, within a fifth of a standard deviation (both stop once
// a step is below a tenth of one); its covariance whole, every entry as the filter's. From
// SolveOptions::full_covariance_below on, each component's covariance and each joint's variance
// as before, the covariance between blocks no joint joins not computed (NaN). An elbow held on
// its limit goes to the filter, which decides whether the limit holds (every entry computed).
TEST_CASE("solve: the sparse path gives the filter's answer and the variances results report",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/cabinet.yaml"));
  SolveOptions sparse, reported, filter;
  reported.full_covariance_below = 0;
  // ... and the same reported by the sparse solver, the joints not eliminated.
  SolveOptions reported_sparse = reported;
  reported_sparse.reduced_below = 0;
  filter.sparse_from_dim = std::numeric_limits<int>::max();
  const int drawer = g.components[g.FindComponent("drawer")].block;
  const int door = g.components[g.FindComponent("door")].block;
  int used = 0;
  for (int seed = 0; seed < 20; ++seed) {
    const bool eliminated = seed < 10;
    SimulateOptions so;
    so.seed = seed % 10;
    so.labels = true;
    so.sample_joints = true;
    const Simulation sim = Simulate(g, so);
    const Solution a = Solve(g, sim.measurements, sparse);
    const Solution c = Solve(g, sim.measurements, eliminated ? reported : reported_sparse);
    const Solution b = Solve(g, sim.measurements, filter);
    INFO("seed " << seed);
    REQUIRE(a.accepted());
    REQUIRE(b.accepted());
    REQUIRE(c.accepted());
    CHECK(a.state.covariance.allFinite());
    CHECK(b.state.covariance.allFinite());
    const Eigen::VectorXd d = LocalCoordinates(g.blocks, b.state.mean, a.state.mean);
    std::vector<int> coordinates;  // every one but the slacks'
    for (const Block& block : g.blocks) {
      const int o = block.tangent_offset, dim = TangentDim(block.kind);
      if (block.kind == BlockKind::kSlack) continue;
      for (int i = o; i < o + dim; ++i) {
        CHECK(std::abs(d[i]) <= 0.2 * std::sqrt(b.state.covariance(i, i)) + 1e-12);
        coordinates.push_back(i);
      }
      const Eigen::MatrixXd pc = c.state.covariance.block(o, o, dim, dim);
      const Eigen::MatrixXd pb = b.state.covariance.block(o, o, dim, dim);
      CHECK((pc - pb).norm() <= 0.01 * pb.norm());
    }
    // Every entry, as a share of the two standard deviations it relates.
    double worst = 0;
    for (int i : coordinates) {
      for (int j : coordinates) {
        const double scale = std::sqrt(b.state.covariance(i, i) * b.state.covariance(j, j));
        worst =
            std::max(worst, std::abs(a.state.covariance(i, j) - b.state.covariance(i, j)) / scale);
      }
    }
    CHECK(worst <= 0.01);
    const JointEstimates qa = EstimateJoints(g, a.state), qb = EstimateJoints(g, b.state),
                         qc = EstimateJoints(g, c.state);
    for (int k = 0; k < qa.values.size(); ++k) {
      CHECK(std::abs(qa.covariance(k, k) - qb.covariance(k, k)) <= 0.01 * qb.covariance(k, k));
      CHECK(std::abs(qc.covariance(k, k) - qb.covariance(k, k)) <= 0.01 * qb.covariance(k, k));
    }
    CHECK(b.estimator == Estimator::kFilter);
    CHECK((a.estimator == Estimator::kFilter) == (c.estimator == Estimator::kFilter));
    CHECK((c.estimator != Estimator::kFilter) == !c.state.covariance.allFinite());
    if (a.estimator == Estimator::kFilter) continue;  // the filter's: a slack on its boundary
    CHECK(a.estimator == Estimator::kReduced);        // the joints eliminated
    CHECK(c.estimator == (eliminated ? Estimator::kReduced : Estimator::kSparse));
    ++used;
    const Block& bd = g.blocks[drawer];
    const Block& bo = g.blocks[door];
    // The drawer and the door are joined by no joint (both hang on the carcass).
    CHECK(std::isnan(c.state.covariance(bd.tangent_offset, bo.tangent_offset)));
    CHECK(std::isfinite(a.state.covariance(bd.tangent_offset, bo.tangent_offset)));
  }
  CHECK(used >= 16);

  // An elbow 1 degree beyond its lower limit: held on the limit, so the filter solved it.
  const ConstraintGraph elbow = LoadModelFromString(kElbow, "elbow.yaml", ".");
  std::mt19937 rng(1);
  const Values truth = ElbowAt(elbow, -1 * M_PI / 180, RandomPose(rng, 1.0));
  const MeasurementSet set = Measure3d(elbow, truth, rng, 0.002);
  const Solution on = Solve(elbow, set, sparse), reference = Solve(elbow, set, filter);
  REQUIRE(on.accepted());
  CHECK(on.estimator == Estimator::kFilter);
  CHECK(on.state.covariance.allFinite());
  CHECK(LocalCoordinates(elbow.blocks, reference.state.mean, on.state.mean)
            .lpNorm<Eigen::Infinity>() == 0);
}

TEST_CASE("solve: NEES over 200 simulated lamps and 200 hinged boxes lies in its 99% interval",
          "[interp][heavy]") {
  for (const char* file : {"examples/lamp.yaml", "examples/hinged-box.yaml"}) {
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    int better = 0;
    const auto [total, dof] = TotalNees(g, 200, true, &better);
    CHECK(better == 200);
    const auto [lo, hi] = ChiSquare99(dof);
    INFO(file << ": total NEES " << total << " over " << dof << " DOF, 99% interval [" << lo << ", "
              << hi << "]");
    CHECK(dof == 200 * AnalyzeDof(g, g.nominal).dof);
    CHECK(total > lo);
    CHECK(total < hi);
  }
}

TEST_CASE("solve: the fit's chi-square over 200 lamps and 200 hinged boxes follows its law",
          "[interp][heavy]") {
  // Measurements with the stated noise: the sum of the solutions' chi-squares lies in the 99 %
  // interval of a chi-square with the sum of their dof, each dof is the residuals less the
  // model's degrees of freedom, and p-values below 0.01 are as rare as they should be.
  for (const char* file : {"examples/lamp.yaml", "examples/hinged-box.yaml"}) {
    CAPTURE(file);
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    const int model_dof = AnalyzeDof(g, g.nominal).dof;
    double total = 0;
    int dof = 0, small_p = 0;
    for (int trial = 0; trial < 200; ++trial) {
      SimulateOptions options;
      options.seed = 900 + trial;
      options.labels = true;
      const Simulation sim = Simulate(g, options);
      const Solution s = Solve(g, sim.measurements);
      REQUIRE(s.accepted());
      const Fit& fit = s.analysis.fit;
      CHECK(fit.residuals == 3 * static_cast<int>(sim.measurements.points.size()));
      CHECK(s.analysis.determined == model_dof);
      CHECK(s.analysis.model_dof == model_dof);
      CHECK(fit.dof == fit.residuals - model_dof);
      CHECK(s.undetermined.empty());
      total += fit.chi2;
      dof += fit.dof;
      small_p += fit.p_value < 0.01;
    }
    const auto [lo, hi] = ChiSquare99(dof);
    INFO("total chi-square " << total << " over " << dof << " dof, 99% interval [" << lo << ", "
                             << hi << "]; p < 0.01 in " << small_p << " of 200");
    CHECK(total > lo);
    CHECK(total < hi);
    CHECK(small_p <= 7);  // binomial(200, 0.01): P(X > 7) < 0.001
  }
}

TEST_CASE("solve: a measurement the model cannot fit makes the solution not accepted",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  SimulateOptions options;
  options.labels = true;
  Simulation sim = Simulate(g, options);
  REQUIRE(Solve(g, sim.measurements).accepted());
  // One corner 10 sigmas off: within the outlier gate when left in (6.8 sigmas is the gate of
  // one point; the fit sees the whole set), so only the fit can refuse it.
  sim.measurements.points[3].xyz += Eigen::Vector3d(0.02, 0, 0);
  const Solution s = Solve(g, sim.measurements);
  CHECK(s.summary.converged);
  CHECK_FALSE(s.fits);
  CHECK_FALSE(s.accepted());
  CHECK(s.analysis.fit.p_value < 1e-3);
}

TEST_CASE("solve: a folding ruler from one image: every answer accepted is right", "[interp]") {
  // A nearly flat object seen in one image can end in a mirrored minimum; the mirrored starts
  // find the right one, and whatever is accepted is right (its joints within 5 standard
  // deviations and 10 degrees of the truth).
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/folding-ruler.yaml"));
  int accepted[2] = {0, 0}, wrong[2] = {0, 0};
  for (int explore = 0; explore < 2; ++explore) {
    for (unsigned seed = 1; seed <= 20; ++seed) {
      CAPTURE(explore, seed);
      SimulateOptions sim_options;
      sim_options.seed = seed;
      sim_options.labels = true;
      sim_options.sample_joints = true;
      sim_options.camera = testing::Pinhole();
      const Simulation sim = Simulate(g, sim_options);
      SolveOptions options;
      options.reject_outliers = true;
      options.explore_starts = explore == 1;
      const Solution s = Solve(g, sim.measurements, options);
      if (!s.accepted()) continue;
      ++accepted[explore];
      const JointEstimates q = EstimateJoints(g, s.state);
      const Eigen::VectorXd truth = JointValues(g, sim.truth);
      for (int j = 0; j < truth.size(); ++j) {
        const double error = std::abs(q.values[j] - truth[j]);
        if (error > 10 * M_PI / 180 && error > 5 * std::sqrt(q.covariance(j, j))) {
          ++wrong[explore];
          break;
        }
      }
      CHECK(s.rejected.empty());  // no outliers were simulated
    }
  }
  INFO("accepted " << accepted[0] << " and " << accepted[1] << " of 20, wrong " << wrong[0]
                   << " and " << wrong[1]);
  CHECK(wrong[0] == 0);
  CHECK(wrong[1] == 0);
  CHECK(accepted[1] >= 18);
  CHECK(accepted[0] < accepted[1]);  // what the mirrored starts are for
}

TEST_CASE("solve: a small square far off in one image has two answers, both said", "[interp]") {
  // Four corners of a 100 mm square 3 m away, turned 40 degrees: the square and its mirror
  // image about the line of sight project within a pixel of each other.
  const ConstraintGraph g = LoadModelFromString(R"(
name: square
units: {length: mm}
components:
  plate:
    points:
      a: [0, 0, 0]
      b: [100, 0, 0]
      c: [100, 100, 0]
      d: [0, 100, 0]
)",
                                                     "square.yaml", testing::SourcePath("examples"));
  const Camera camera = testing::Pinhole();
  int both = 0, truth_among = 0;
  for (int seed = 0; seed < 20; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> pixel(0, 0.5);
    const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(40 * M_PI / 180, Eigen::Vector3d(1, 0.3, 0).normalized())),
                       Eigen::Vector3d(-0.05, -0.05, 3));
    const Values truth = Moved(g, pose);
    const MeasurementSet set = MeasureImage(g, truth, camera, pixel, rng);
    SolveOptions options;
    const Solution s = Solve(g, set, options);
    REQUIRE(s.accepted());
    const auto turn = [&](const Values& v) {
      return v.poses[0].rotation.angularDistance(truth.poses[0].rotation) * 180 / M_PI;
    };
    both += !s.alternatives.empty();
    bool found = turn(s.state.mean) < 10;
    for (const Solution::Alternative& a : s.alternatives) {
      CHECK(a.fit.p_value >= options.min_p_value);
      CHECK(turn(a.mean) != Approx(turn(s.state.mean)).margin(3));
      found |= turn(a.mean) < 10;
    }
    truth_among += found;
  }
  CHECK(both >= 15);
  CHECK(truth_among == 20);
}

TEST_CASE("solve: a measurement nothing else checks is never left out", "[interp]") {
  // The hinged box's corners and one lid corner, that corner 0.3 m off: it is far from where the
  // lid can be, but it is the only witness of the lid's angle. Left out, the angle would be
  // anyone's guess and the rest would fit; it stays, and the solution is not accepted.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  std::mt19937 rng(4);
  const MeasurementSet all = Measure3d(g, g.nominal, rng, 0.001);
  MeasurementSet set;
  for (const MeasuredPoint& m : all.points) {
    if (m.label.rfind("box.", 0) == 0 || m.label == "lid.l000") set.points.push_back(m);
  }
  set.points.back().xyz += Eigen::Vector3d(0.3, 0, 0);
  SolveOptions options;
  options.reject_outliers = true;
  const Solution s = Solve(g, set, options);
  CHECK(s.rejected.empty());
  CHECK_FALSE(s.accepted());
  // With a second lid corner the two check each other, and the far one is left out.
  for (const MeasuredPoint& m : all.points) {
    if (m.label == "lid.l100") set.points.push_back(m);
  }
  const Solution checked = Solve(g, set, options);
  REQUIRE(checked.rejected.size() == 1);
  CHECK(set.points[checked.rejected[0].measurement].label == "lid.l000");
  CHECK(checked.accepted());
}

TEST_CASE("solve: what the measurements leave free is named", "[interp]") {
  // The hinged box measured on the box alone: the lid's angle is anyone's guess.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  std::mt19937 rng(3);
  const MeasurementSet all = Measure3d(g, g.nominal, rng, 0.001);
  MeasurementSet box;
  for (const MeasuredPoint& m : all.points) {
    if (m.label.rfind("box.", 0) == 0) box.points.push_back(m);
  }
  const Solution s = Solve(g, box);
  CHECK(s.analysis.model_dof == 7);
  CHECK(s.analysis.determined == 6);
  CHECK(s.undetermined == std::vector<std::string>{"lid", "joint hinge"});
  // All of it measured: nothing free.
  CHECK(Solve(g, all).undetermined.empty());
  // One lid corner on the hinge's axis is no help; one off it fixes the angle.
  MeasurementSet on_axis = box, off_axis = box;
  for (const MeasuredPoint& m : all.points) {
    if (m.label == "lid.l010") on_axis.points.push_back(m);
    if (m.label == "lid.l000") off_axis.points.push_back(m);
  }
  CHECK(Solve(g, on_axis).undetermined == std::vector<std::string>{"lid", "joint hinge"});
  CHECK(Solve(g, off_axis).undetermined.empty());
}

TEST_CASE("solve: a real measurement is never left out of an accepted solution", "[interp]") {
  // Two gross outliers among a lamp's 18 points, 20-250 mm off: each solution accepted leaves
  // out both and no other; the rest are refused, not wrong.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  const double gate = std::sqrt(ChiSquareQuantile(1 - 1e-9, 3));
  int accepted = 0;
  for (int trial = 0; trial < 40; ++trial) {
    CAPTURE(trial);
    SimulateOptions options;
    options.seed = 300 + trial;
    options.labels = true;
    Simulation sim = Simulate(g, options);
    std::mt19937 rng(trial);
    std::uniform_int_distribution<int> pick(0, static_cast<int>(sim.measurements.points.size()) - 1);
    std::normal_distribution<double> far(0, 0.08);
    const int a = pick(rng);
    int b = pick(rng);
    while (b == a) b = pick(rng);
    for (int i : {a, b}) {
      Eigen::Vector3d off(far(rng), far(rng), far(rng));
      while (off.norm() < 0.02) off *= 2;
      sim.measurements.points[i].xyz += off;
    }
    SolveOptions solve;
    solve.reject_outliers = true;
    const Solution s = Solve(g, sim.measurements, solve);
    if (!s.accepted()) continue;
    ++accepted;
    CHECK(s.rejected.size() == 2);
    for (const Solution::Rejection& r : s.rejected) {
      CHECK((r.measurement == a || r.measurement == b));
      CHECK(r.sigmas > gate);
    }
  }
  CHECK(accepted >= 36);
}

}  // namespace
}  // namespace cfuse
