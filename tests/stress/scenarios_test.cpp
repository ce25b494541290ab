// Numerical stress (issue 8, "Reliability"), part 2: degenerate models and data, each through
// the library (Solve) and the `cfuse` program. Every one must end in a clear status, with no
// NaN or infinity anywhere in the result:
//   - 2 (bad input), one located message, no output file: the model itself is bad;
//   - 1, the estimate written and a message saying what went wrong;
//   - 0 with a correct answer.
// Each case says what a demanding user expects, and why.
#include <fmt/format.h>
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/measurements/image_point.h"
#include "cli/results.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

// A scratch directory of its own per case.
struct Workspace {
  explicit Workspace(const std::string& name)
      : dir(fs::temp_directory_path() / "cfuse_stress_test" / name) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  std::string Write(const std::string& file, const std::string& text) const {
    std::ofstream(dir / file) << text;
    return (dir / file).string();
  }
  std::string Path(const std::string& file) const { return (dir / file).string(); }
  fs::path dir;
};

// The program, as a user runs it.
struct Run {
  int status = -1;
  std::string out, err;
};

Run Cfuse(const Workspace& ws, const std::string& arguments) {
  const std::string out = ws.Path("stdout.txt"), err = ws.Path("stderr.txt");
  const int raw = std::system(
      (std::string("'") + CFUSE_EXE + "' " + arguments + " > '" + out + "' 2> '" + err + "'")
          .c_str());
  Run r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  auto read = [](const std::string& path) {
    std::ifstream in(path);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  r.out = read(out);
  r.err = read(err);
  fs::remove(out);
  fs::remove(err);
  return r;
}

// Every number in a result is finite, and null appears only where the format allows it: an
// unmatched measurement in `matches`, `status.residual_variance` (docs/formats.md). nlohmann
// writes NaN and infinity as null, so this also finds those.
void CheckFiniteJson(const nlohmann::json& j, const std::string& path = "") {
  INFO("at " << path);
  if (j.is_null()) {
    CHECK((path.rfind("/matches/", 0) == 0 || path == "/status/residual_variance"));
  } else if (j.is_number_float()) {
    CHECK(std::isfinite(j.get<double>()));
  } else if (j.is_object()) {
    for (const auto& [key, value] : j.items()) CheckFiniteJson(value, path + "/" + key);
  } else if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) CheckFiniteJson(j[i], path + "/" + std::to_string(i));
  }
}

// `cfuse solve` writing RESULT: its status, stderr and result, the result checked finite.
struct SolveRun {
  Run run;
  nlohmann::json result;
};

SolveRun CfuseSolve(const Workspace& ws, const std::string& model, const std::string& meas) {
  SolveRun s;
  const std::string result = ws.Path("result.json");
  fs::remove(result);
  s.run = Cfuse(ws, fmt::format("solve '{}' --measurements '{}' -o '{}'", model, meas, result));
  INFO(s.run.err);
  if (s.run.status == 0 || s.run.status == 1) {
    REQUIRE(fs::exists(result));
    std::ifstream in(result);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK_THAT(text, !Contains("NaN") && !Contains("Infinity"));
    s.result = nlohmann::json::parse(text);
    CheckFiniteJson(s.result);
  } else {
    // Bad input: nothing written, not even a temporary file beside it.
    CHECK_FALSE(fs::exists(result));
    for (const auto& e : fs::directory_iterator(ws.dir)) {
      CHECK_THAT(e.path().filename().string(), !StartsWith("result.json"));
    }
  }
  return s;
}

// Solve as `cfuse solve` does it: PnP starts, gross outliers left out.
Solution SolveAsCli(const ConstraintGraph& g, const MeasurementSet& set) {
  SolveOptions options;
  options.reject_outliers = true;
  return Solve(g, set, options);
}

// The library's result is finite throughout.
void CheckFinite(const Solution& s) {
  CHECK(s.state.covariance.allFinite());
  for (const Eigen::Vector3d& p : s.state.mean.points) CHECK(p.allFinite());
  for (const Rigid3d& p : s.state.mean.poses) {
    CHECK(p.translation.allFinite());
    CHECK(p.rotation.coeffs().allFinite());
  }
  for (double x : s.state.mean.slacks) CHECK(std::isfinite(x));
  CHECK(std::isfinite(s.summary.max_constraint_residual));
  for (const Solution::Rejection& r : s.rejected) CHECK(std::isfinite(r.sigmas));
}

Eigen::Vector3d PointOf(const ConstraintGraph& g, const Solution& s, const std::string& name) {
  return s.state.mean.points[g.blocks[g.components[g.FindComponent(name)].block].index];
}

// Two points 1 m apart, measured 2 mm from there.
const char* kTwoPointsMeasured = R"({"points": [
  {"xyz": [0.001, 0, 1], "sigma": 0.002, "label": "a"},
  {"xyz": [1.0, 0.002, 1], "sigma": 0.002, "label": "b"}]})";

// (a) Contradictory constraints. Nothing can satisfy them all: the user must learn which one
// gave way. Expected: status 1, the estimate written (finite), the constraint named.
TEST_CASE("stress: contradictory constraints end in status 1 naming the constraint", "[stress]") {
  struct Case {
    const char* name;
    const char* model;
    const char* measurements;
    const char* message;  // on stderr
  };
  const Case cases[] = {
      // distance(a, b) is 1 m and 2 m: the second is refused as contradicting the first.
      {"distances",
       "points: {a: [0, 0, 0], b: [1, 0, 0]}\nconstraints:\n"
       "  - distance(a, b) == 1 m\n  - distance(a, b) == 2 m\n",
       kTwoPointsMeasured, "cfuse: contradictory constraints or measurements, not fused: c2\n"},
      // Parallel and perpendicular at once: both nonlinear, they are fused in turn and fight;
      // the passes end with one of them violated, which is named with its place in the file.
      {"parallel",
       "points: {a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0], d: [1, 1, 0]}\n"
       "constraints:\n  - parallel(b - a, d - c)\n  - perpendicular(b - a, d - c)\n",
       R"({"points": [{"xyz": [0, 0, 1], "sigma": 0.002, "label": "a"},
                      {"xyz": [1, 0, 1], "sigma": 0.002, "label": "b"},
                      {"xyz": [0, 1, 1], "sigma": 0.002, "label": "c"},
                      {"xyz": [1, 1, 1], "sigma": 0.002, "label": "d"}]})",
       "farthest from holding: 'c2' (perpendicular(b - a, d - c)) at "},
      // A range and a bound that cannot both hold.
      {"range",
       "points: {a: [0, 0, 0], b: [1.5, 0, 0]}\nconstraints:\n"
       "  - distance(a, b) in [1 m, 2 m]\n  - distance(a, b) >= 3 m\n",
       kTwoPointsMeasured, "cfuse: contradictory constraints or measurements, not fused: c2\n"},
      {"bounds",
       "points: {a: [0, 0, 0], b: [1.5, 0, 0]}\nconstraints:\n"
       "  - distance(a, b) >= 2 m\n  - distance(a, b) <= 1 m\n",
       kTwoPointsMeasured, "cfuse: contradictory constraints or measurements, not fused: c2\n"},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const Workspace ws(std::string("contradictory_") + c.name);
    const std::string model = ws.Write("model.yaml", c.model);
    const std::string meas = ws.Write("m.json", c.measurements);
    const ConstraintGraph g = LoadModel(model);
    const Solution s = SolveAsCli(g, ReadMeasurements(meas));
    CheckFinite(s);
    CHECK((!s.contradictions.empty() || !s.summary.converged));
    CHECK(s.invalid.empty());
    const SolveRun r = CfuseSolve(ws, model, meas);
    CHECK(r.run.status == 1);
    CHECK_THAT(r.run.err, Contains(c.message));
    CHECK(r.result["status"]["converged"] == false);
  }
}

// (b) Redundant constraints: the same condition written twice in other forms, and a closed
// loop. They add no information and no conflict. Expected: status 0, every constraint met.
TEST_CASE("stress: redundant constraints and a closed loop solve with status 0", "[stress]") {
  const Workspace ws("redundant");
  const std::string model =
      ws.Write("model.yaml", R"(points: {a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0]}
constraints:
  - distance(a, b) == 1 m
  - norm(b - a) == 1 m
  - distance(a, b) == nominal
  - dot(b - a, c - a) == 0
  - perpendicular(b - a, c - a)
  - angle(b, a, c) == 90 deg
)");
  const std::string meas = ws.Write("m.json", R"({"points": [
    {"xyz": [0.001, 0, 1], "sigma": 0.002, "label": "a"},
    {"xyz": [1.0, 0.003, 1], "sigma": 0.002, "label": "b"},
    {"xyz": [0, 1, 1.002], "sigma": 0.002, "label": "c"}]})");
  const ConstraintGraph g = LoadModel(model);
  const Solution s = SolveAsCli(g, ReadMeasurements(meas));
  CheckFinite(s);
  REQUIRE(s.summary.converged);
  CHECK(s.contradictions.empty());
  const Eigen::Vector3d a = PointOf(g, s, "a"), b = PointOf(g, s, "b"), c = PointOf(g, s, "c");
  CHECK(std::abs((b - a).norm() - 1) < 1e-8);
  CHECK(std::abs((b - a).dot(c - a)) < 1e-8);
  const SolveRun r = CfuseSolve(ws, model, meas);
  CHECK(r.run.status == 0);
  CHECK(r.run.err.empty());

  // A four-bar linkage (docs/dsl.md §13): joints from the ground to the crank and the rocker,
  // the loop closed by the coupler's length, and closed again by the same length written as a
  // norm. Simulated, it must come back to the truth.
  const Workspace loop_ws("closed_loop");
  const std::string linkage = loop_ws.Write("linkage.yaml", R"(name: four-bar linkage
units: {length: mm, angle: deg}
components:
  ground:
    pose: {xyz: [0, 0, 0]}
    points: {a: [0, 0, 0], d: [400, 0, 0], e: [0, 100, 0]}
  crank:
    points: {base: [0, 0, 0], pin: [100, 0, 0], mark: [50, 20, 0]}
  rocker:
    points: {base: [0, 0, 0], pin: [250, 0, 0], mark: [120, -20, 0]}
joints:
  drive:
    type: revolute
    parent: ground
    child: crank
    axis: [0, 0, 1]
    position: 60
  follow:
    type: revolute
    parent: ground
    child: rocker
    origin: {xyz: [400, 0, 0]}
    axis: [0, 0, 1]
    position: 100
constraints:
  - name: coupler
    expr: distance(crank.pin, rocker.pin) == nominal
  - name: coupler_again
    expr: norm(rocker.pin - crank.pin) == nominal
)");
  const ConstraintGraph lg = LoadModel(linkage);
  SimulateOptions so;
  so.seed = 11;
  so.labels = true;
  so.noise = 0.0005;
  const Simulation sim = Simulate(lg, so);
  const Solution ls = SolveAsCli(lg, sim.measurements);
  CheckFinite(ls);
  REQUIRE(ls.summary.converged);
  CHECK(ls.contradictions.empty());
  for (size_t i = 0; i < lg.components.size(); ++i) {
    const Rigid3d& truth = sim.truth.poses[lg.blocks[lg.components[i].block].index];
    const Rigid3d& found = ls.state.mean.poses[lg.blocks[lg.components[i].block].index];
    CHECK((found.translation - truth.translation).norm() < 0.005);
  }
  // The same through the program.
  loop_ws.Write("m.json", cli::MeasurementsJson(sim.measurements).dump());
  const SolveRun lr = CfuseSolve(loop_ws, linkage, loop_ws.Path("m.json"));
  CHECK(lr.run.status == 0);
  CHECK(lr.result["status"]["converged"] == true);
}

// (c) A zero-length distance: distance(a, b) == 0 holds only where the distance has no
// derivative, so the filter can never fuse it (a solve used to end "the constraints hold only
// to 0.0995" without saying why). It is the model that is wrong, and `a == b` says the same
// thing fusibly. Expected: status 2 at the constraint, with that advice; no output.
TEST_CASE("stress: a zero-length distance is refused at the constraint, with advice", "[stress]") {
  struct Case {
    const char* name;
    const char* model;
    const char* message;
  };
  const Case cases[] = {
      {"apart", "points: {a: [0, 0, 0], b: [0.1, 0, 0]}\nconstraints:\n  - distance(a, b) == 0 m\n",
       "model.yaml:3:5: error: constraint 'c1': a distance or a norm required to be 0 holds only "
       "where it has no derivative, so the estimator cannot fuse it: write the points equal "
       "(a == b)"},
      {"norm_at_most",
       "points: {a: [0, 0, 0], b: [0.1, 0, 0]}\nconstraints:\n"
       "  - norm(b - a) <= 0 m\n",
       "model.yaml:3:5: error: constraint 'c1': a distance or a norm required to be 0"},
      // Coincident at the nominal geometry: not differentiable there.
      {"coincident",
       "points: {a: [0, 0, 0], b: [0, 0, 0]}\nconstraints:\n"
       "  - distance(a, b) == 0 m\n",
       "model.yaml:3:5: error: constraint 'c1' (distance(a, b) == 0 m) is not differentiable at "
       "the nominal geometry"},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const Workspace ws(std::string("zero_length_") + c.name);
    const std::string model = ws.Write("model.yaml", c.model);
    try {
      LoadModel(model);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().line == 3);
      CHECK(e.where().column == 5);
    }
    const SolveRun r = CfuseSolve(ws, model, ws.Write("m.json", kTwoPointsMeasured));
    CHECK(r.run.status == 2);
    CHECK_THAT(r.run.err, StartsWith(model + ":3:5: error: ") && Contains(c.message));
  }
}

// (d) Collinear points given to coplanar. At the nominal geometry the plane is undetermined:
// the model is wrong, status 2 at the constraint. Measured collinear (the model's points are
// not): collinear points are coplanar, and the estimate must say so: status 0, every
// constraint met, the covariance finite (the plane's normal is undefined there).
TEST_CASE("stress: coplanar on collinear points: refused in the model, met in the data",
          "[stress]") {
  const Workspace ws("coplanar_collinear");
  const std::string bad =
      ws.Write("collinear.yaml",
               "points: {a: [0, 0, 0], b: [1, 0, 0], c: [2, 0, 0], d: [3, 0, 0]}"
               "\nconstraints:\n  - coplanar(a, b, c, d)\n");
  const SolveRun refused = CfuseSolve(ws, bad, ws.Write("m.json", kTwoPointsMeasured));
  CHECK(refused.run.status == 2);
  CHECK_THAT(refused.run.err,
             Contains("collinear.yaml:3:5: error: constraint 'c1': coplanar: the points are "
                      "collinear (or coincide) at the nominal geometry"));

  const std::string model = ws.Write("square.yaml",
                                     "points: {a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0], d: [1, 1, "
                                     "0]}\nconstraints:\n  - coplanar(a, b, c, d)\n");
  for (const char* noise : {"0", "0.001"}) {
    INFO("noise " << noise);
    const std::string meas = ws.Write("line.json", fmt::format(R"({{"points": [
      {{"xyz": [0, 0, 1], "sigma": 0.002, "label": "a"}},
      {{"xyz": [1, {0}, 1], "sigma": 0.002, "label": "b"}},
      {{"xyz": [2, 0, 1], "sigma": 0.002, "label": "c"}},
      {{"xyz": [3, -{0}, 1], "sigma": 0.002, "label": "d"}}]}})",
                                                               noise));
    const ConstraintGraph g = LoadModel(model);
    const Solution s = SolveAsCli(g, ReadMeasurements(meas));
    CheckFinite(s);
    CHECK(s.summary.converged);
    CHECK(s.invalid.empty());
    const SolveRun r = CfuseSolve(ws, model, meas);
    CHECK(r.run.status == 0);
  }
}

// (e) Image points whose model point is at or behind the camera centre: the pinhole has no
// projection there (Camera::Project gives NaN rather than divide by zero). A demanding user
// expects that measurement not fused and named, the others used: status 1 (as for a refused
// contradiction), the estimate written. It used to make the component's whole stacked
// measurement invalid, silently: status 0, the rod at its start with the prior's covariance
// (a sigma of 9 m).
std::string RodModel() {
  // A rod along its z axis, seen end-on from 1 m: its tail reaches back to the camera.
  return R"(components:
  rod:
    points: {p0: [0.1, 0, 0], p1: [0, 0.1, 0], p2: [-0.1, 0, 0], p3: [0, -0.1, 0],
             p4: [0.05, 0.05, 0.2], p5: [-0.05, 0.05, 0.3], tail: [0, 0, -1]}
)";
}

TEST_CASE("stress: an image point at or behind the camera is left out and named", "[stress]") {
  const Workspace ws("camera_centre");
  const std::string model = ws.Write("rod.yaml", RodModel());
  const ConstraintGraph g = LoadModel(model);
  const Camera camera = testing::Pinhole();
  // The rod 1 m in front of the camera: its tail exactly at the camera centre, then behind it.
  for (double depth : {1.0, 0.9}) {
    INFO("tail at z = " << 1 - depth);
    const Rigid3d truth(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.01, -0.02, depth));
    nlohmann::json j;
    j["camera"] = {{"fx", camera.fx}, {"fy", camera.fy},       {"cx", camera.cx},
                   {"cy", camera.cy}, {"width", camera.width}, {"height", camera.height}};
    j["points"] = nlohmann::json::array();
    std::mt19937 rng(3);
    std::normal_distribution<double> pixel(0, 0.5);
    for (const FeaturePoint& p : g.components[0].points) {
      const Eigen::Vector3d x = truth * p.position;
      // The tail has no image; a careless labelling gives it the principal point.
      const Eigen::Vector2d uv =
          x.z() > 0
              ? Eigen::Vector2d(camera.Project<double>(x) + Eigen::Vector2d(pixel(rng), pixel(rng)))
              : Eigen::Vector2d(camera.cx, camera.cy);
      j["points"].push_back({{"uv", {uv.x(), uv.y()}}, {"sigma", 0.5}, {"label", "rod." + p.name}});
    }
    const std::string meas = ws.Write("m.json", j.dump());
    const Solution s = SolveAsCli(g, ReadMeasurements(meas));
    CheckFinite(s);
    // The other six measured the rod.
    const Rigid3d& found = s.state.mean.poses[0];
    CHECK((found.translation - truth.translation).norm() < 0.01);
    const SolveRun r = CfuseSolve(ws, model, meas);
    if (depth < 1) {
      // Behind the camera at the estimate too: not fused, status 1.
      REQUIRE(s.invalid.size() == 1);
      CHECK_THAT(s.invalid[0], StartsWith("measurement 6 (rod.tail): its model point is at or "
                                          "behind the camera"));
      CHECK(r.run.status == 1);
      CHECK_THAT(r.run.err, Contains("cfuse: not fused, its residual not finite: measurement 6 "
                                     "(rod.tail): its model point is at or behind the camera"));
      CHECK(r.result["status"]["invalid"].size() == 1);
    } else {
      // At the centre: the estimate puts it a hair in front or behind, so it is either not
      // fused (status 1) or, thousands of pixels off there, left out as an outlier (status 0
      // with a warning); never fused.
      CHECK(s.invalid.size() + s.rejected.size() == 1);
      CHECK_THAT(r.run.err, Contains("measurement 6 (rod.tail)"));
      CHECK(r.run.status == (s.invalid.empty() ? 0 : 1));
    }
  }

  // Too few points for a pose in closed form (3): the rod starts at its nominal pose, around
  // the camera centre, every point at or behind it. Nothing can be fused; all are named.
  nlohmann::json j;
  j["camera"] = {{"fx", 800}, {"fy", 800},    {"cx", 320},
                 {"cy", 240}, {"width", 640}, {"height", 480}};
  j["points"] = {{{"uv", {400, 240}}, {"sigma", 1}, {"label", "rod.p0"}},
                 {{"uv", {320, 320}}, {"sigma", 1}, {"label", "rod.p1"}},
                 {{"uv", {240, 240}}, {"sigma", 1}, {"label", "rod.p2"}}};
  const std::string meas = ws.Write("three.json", j.dump());
  const Solution s = SolveAsCli(g, ReadMeasurements(meas));
  CheckFinite(s);
  CHECK(s.invalid.size() == 3);
  const SolveRun r = CfuseSolve(ws, model, meas);
  CHECK(r.run.status == 1);
  CHECK_THAT(r.run.err, Contains("measurement 0 (rod.p0): its model point is at or behind"));
}

// During the iterations of one update: a point just in front of the camera, measured far off
// in the image, whose Gauss-Newton steps carry it through the camera plane. Expected: the
// update refused as invalid with the state as it was, or fused; never a NaN in the state.
TEST_CASE("stress: an image update crossing the camera plane leaves a finite state", "[stress]") {
  const Camera camera = testing::Pinhole();
  std::vector<Block> blocks = {{BlockKind::kPoint, 0, 0, "p"}};
  int invalid = 0;
  for (double z : {1e-9, 1e-3, 0.05}) {
    for (double u : {-1e6, -3000.0, 5000.0, 1e9}) {
      INFO("z " << z << ", u " << u);
      Values start;
      start.points = {Eigen::Vector3d(0.01, 0.0, z)};
      GaussianState state = MakePrior(blocks, start, PriorScale{});
      const GaussianState before = state;
      const Factor f{std::make_shared<ImagePointResidual>(camera, Eigen::Vector2d(u, 240)),
                     {0},
                     Eigen::Matrix2d::Identity(),
                     "image point"};
      const FusionSummary s = Fuse(f, &state);
      CHECK(state.covariance.allFinite());
      CHECK(state.mean.points[0].allFinite());
      if (s.status == FusionSummary::Status::kInvalid) {
        ++invalid;
        CHECK(s.invalid_row == 0);
        CHECK(state.covariance == before.covariance);
        CHECK(state.mean.points[0] == before.mean.points[0]);
      }
    }
  }
  CHECK(invalid > 0);  // some did cross
}

// (f) Gross outliers: one measurement 10^6 standard deviations from where the rest put its
// point (a mislabelled point, a sensor glitch). Fused, it dragged the whole lamp away, 1 km,
// and `cfuse solve` blamed two constraints as contradictory. A demanding user expects it gated
// out, named, and the rest solved correctly: status 0 with a warning, the measurement in
// `status.rejected`.
TEST_CASE("stress: a measurement 10^6 sigma off is rejected, the rest solved correctly",
          "[stress]") {
  const Workspace ws("outlier_3d");
  const std::string model = testing::SourcePath("examples/lamp.yaml");
  const ConstraintGraph g = LoadModel(model);
  SimulateOptions so;
  so.seed = 3;
  so.labels = true;
  Simulation sim = Simulate(g, so);
  MeasuredPoint& bad = sim.measurements.points[5];
  bad.xyz.x() += 1e6 * std::sqrt(bad.cov3(0, 0));
  const Solution s = SolveAsCli(g, sim.measurements);
  CheckFinite(s);
  REQUIRE(s.rejected.size() == 1);
  CHECK(s.rejected[0].measurement == 5);
  CHECK(s.rejected[0].sigmas > 1e5);
  CHECK(s.summary.converged);
  double worst = 0;
  for (size_t i = 0; i < g.components.size(); ++i) {
    const int b = g.blocks[g.components[i].block].index;
    worst = std::max(worst, (s.state.mean.points[b] - sim.truth.points[b]).norm());
  }
  CHECK(worst < 0.01);

  const SolveRun r =
      CfuseSolve(ws, model, ws.Write("m.json", cli::MeasurementsJson(sim.measurements).dump()));
  CHECK(r.run.status == 0);
  CHECK_THAT(r.run.err, StartsWith("cfuse: warning: measurement 5 (" + bad.label +
                                   ") left out as an outlier: "));
  CHECK(r.result["status"]["rejected"].size() == 1);
  CHECK(r.result["status"]["rejected"][0]["measurement"] == 5);
  CHECK(r.result["status"]["converged"] == true);
}

// The same in an image: the hinged box seen by a camera, one image point 10^6 pixels (sigmas)
// off (it was 224 m off, "the constraints hold only to 155"). The start in closed form (PnP)
// is dragged too, with points behind the camera; solved again without the outlier it is not.
TEST_CASE("stress: an image point 10^6 sigma off is rejected, the box found", "[stress]") {
  const Workspace ws("outlier_2d");
  const std::string model = testing::SourcePath("examples/hinged-box.yaml");
  const ConstraintGraph g = LoadModel(model);
  SimulateOptions so;
  so.seed = 4;
  so.labels = true;
  so.camera = testing::Pinhole();
  Simulation sim = Simulate(g, so);
  REQUIRE(sim.measurements.points.size() > 8);
  MeasuredPoint& bad = sim.measurements.points[3];
  bad.uv.x() += 1e6 * std::sqrt(bad.cov2(0, 0));
  const Solution s = SolveAsCli(g, sim.measurements);
  CheckFinite(s);
  REQUIRE(s.rejected.size() == 1);
  CHECK(s.rejected[0].measurement == 3);
  CHECK(s.summary.converged);
  for (size_t i = 0; i < g.components.size(); ++i) {
    const int b = g.blocks[g.components[i].block].index;
    CHECK((s.state.mean.poses[b].translation - sim.truth.poses[b].translation).norm() < 0.02);
  }

  const SolveRun r =
      CfuseSolve(ws, model, ws.Write("m.json", cli::MeasurementsJson(sim.measurements).dump()));
  CHECK(r.run.status == 0);
  CHECK_THAT(r.run.err, Contains("left out as an outlier"));
  CHECK(r.result["status"]["rejected"][0]["measurement"] == 3);
}

}  // namespace
}  // namespace cfuse
