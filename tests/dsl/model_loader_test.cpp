// The model DSL: the examples load with the DOF they were designed for, and the language's
// semantics (units, nominal, joints, includes, fixed) build the graph they promise.
#include "cfuse/dsl/model_loader.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "cfuse/constraints/dof.h"
#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/evaluate.h"
#include "constraints/jacobian_checker.h"
#include "row_selection.h"
#include "test_util.h"

namespace cfuse {
namespace {

ConstraintGraph Load(const std::string& yaml) {
  return LoadModelFromString(yaml, "model.yaml", testing::SourcePath("examples"));
}

double MaxNominalResidual(const ConstraintGraph& g) {
  Eigen::VectorXd r;
  EvaluateConstraints(g, g.nominal, &r, nullptr);
  return r.size() ? r.cwiseAbs().maxCoeff() : 0.0;
}

struct ExampleDof {
  const char* file;
  int dof, rigid_body, internal;
};

TEST_CASE("examples: each loads with the DOF it was designed for, nominal geometry consistent",
          "[dsl]") {
  for (const ExampleDof& e :
       {ExampleDof{"examples/lamp.yaml", 11, 6, 5}, ExampleDof{"examples/scissors.yaml", 7, 6, 1},
        ExampleDof{"examples/hinged-box.yaml", 7, 6, 1},
        ExampleDof{"examples/planar-arm.yaml", 3, 0, 3},
        ExampleDof{"examples/four-bar.yaml", 7, 6, 1},
        ExampleDof{"examples/folding-ruler.yaml", 9, 6, 3}}) {
    DYNAMIC_SECTION(e.file) {
      const ConstraintGraph g = LoadModel(testing::SourcePath(e.file));
      const DofReport r = AnalyzeDof(g, g.nominal);
      CHECK(r.dof == e.dof);
      CHECK(r.rigid_body == e.rigid_body);
      CHECK(r.internal == e.internal);
      CHECK(r.redundant.empty());
      CHECK(MaxNominalResidual(g) < 1e-9);
    }
  }
}

TEST_CASE("examples: a loop closure the joints partly imply keeps its independent rows", "[dsl]") {
  // The four-bar's `coupler.end == rocker.pin` repeats, along the parallel revolute axes, what
  // the joints already hold: one of its three rows is left out, the other two are the
  // relation's own values and derivatives.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/four-bar.yaml"));
  const Constraint& loop = g.constraints[g.FindConstraint("loop")];
  CHECK(loop.redundant_rows == 1);
  REQUIRE(loop.residual->dimension() == 2);
  const auto* selection = dynamic_cast<const RowSelection*>(loop.residual.get());
  REQUIRE(selection != nullptr);
  CHECK(selection->inner().dimension() == 3);
  CHECK(g.Describe(loop) == "coupler.end == rocker.pin");
  const DofReport report = AnalyzeDof(g, g.nominal);
  CHECK(report.redundant.empty());
  CHECK(report.dof == 7);
  // Away from the nominal geometry, the selected rows of the relation as written.
  Values x = g.nominal;
  Eigen::VectorXd move = Eigen::VectorXd::Constant(g.tangent_dim(), 0.05);
  Retract(g.blocks, move, &x);
  Eigen::VectorXd all, some;
  Eigen::MatrixXd j_all, j_some;
  EvaluateResidual(selection->inner(), g.blocks, loop.blocks, x, &all, &j_all);
  EvaluateResidual(*loop.residual, g.blocks, loop.blocks, x, &some, &j_some);
  for (int i = 0; i < 2; ++i) {
    const int row = selection->rows()[i];
    CHECK(some[i] == all[row]);
    CHECK(j_some.row(i) == j_all.row(row));
  }
  testing::CheckJacobian(g.blocks, *loop.residual, loop.blocks, x);
}

TEST_CASE("examples: off the constraint surface no row is left out", "[dsl]") {
  // The same loop with the rocker's angle 1 degree off: the nominal geometry violates the
  // closure, where ranks say nothing about the surface, and every row is kept.
  std::ifstream in(testing::SourcePath("examples/four-bar.yaml"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string exact = "position: 75.22868402252183";
  REQUIRE(text.find(exact) != std::string::npos);
  text.replace(text.find(exact), exact.size(), "position: 76.22868402252183");
  const ConstraintGraph g =
      LoadModelFromString(text, "four-bar-open.yaml", testing::SourcePath("examples"));
  const Constraint& loop = g.constraints[g.FindConstraint("loop")];
  CHECK(loop.redundant_rows == 0);
  CHECK(loop.residual->dimension() == 3);
}

TEST_CASE("examples: the lamp is the paper's 23-point model", "[dsl]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  CHECK(g.components.size() == 23);
  CHECK(g.tangent_dim() == 69);
  std::map<std::string, int> kinds;
  for (const Constraint& c : g.constraints) kinds[c.kind_name] += 1;
  CHECK(kinds["distance =="] == 50);
  CHECK(kinds["parallel"] == 2);
  CHECK(kinds["coplanar"] == 4);
}

TEST_CASE("dsl: units convert to metres and radians; bare numbers take the file's units", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
units: {length: mm, angle: deg}
points:
  a: [0, 0, 0]
  b: [300, 0, 0]
  c: [0, "0.4 m", 0]
constraints:
  - distance(a, b) == 30 cm
  - angle(b, a, c) == 90 deg
  - angle(b, a, c) == 1.5707963267948966 rad
)yaml");
  CHECK(g.nominal.points[1].x() == Approx(0.3));
  CHECK(g.nominal.points[2].y() == Approx(0.4));
  CHECK(MaxNominalResidual(g) < 1e-12);
}

TEST_CASE("dsl: nominal is the left-hand side's value in the nominal geometry", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
points: {a: [0, 0, 0], b: [0.3, 0.4, 0], c: [1, 1, 1]}
constraints:
  - distance(a, b) == nominal
  - name: widened
    expr: distance(a, c) in [nominal - 0.1 m, nominal + 0.2 m]
  - c == nominal
)yaml");
  CHECK(MaxNominalResidual(g) < 1e-12);
  CHECK(g.Describe(g.constraints[0]) == "distance(a, b) == 0.5 m");
  CHECK(g.Describe(g.constraints[1]) == "distance(a, c) in [1.63205 m, 1.93205 m]");
  CHECK(g.constraints[2].residual->dimension() == 3);
}

TEST_CASE("dsl: a literal 0 takes the unit of the other side", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
points: {a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0]}
constraints:
  - dot(b - a, c - a) == 0
  - cross(b - a, c - a) - cross(b - a, c - a) == [0, 0, 0]
)yaml");
  CHECK(g.constraints.size() == 2);
  CHECK(MaxNominalResidual(g) < 1e-12);
}

TEST_CASE("dsl: inequalities get a slack at sqrt of their nominal margin", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
points: {a: [0, 0, 0], b: [0.5, 0, 0]}
constraints:
  - name: far
    expr: distance(a, b) >= 0.25 m
  - name: near
    expr: distance(a, b) <= 0.75 m
  - name: between
    expr: distance(a, b) in [0.3 m, 0.9 m]
)yaml");
  REQUIRE(g.nominal.slacks.size() == 3);
  CHECK(g.nominal.slacks[0] == Approx(std::sqrt(0.25)));
  CHECK(g.nominal.slacks[1] == Approx(std::sqrt(0.25)));
  // Range [0.3, 0.9], value 0.5: 1 - ((0.5 - 0.6) / 0.3)^2.
  CHECK(g.nominal.slacks[2] == Approx(std::sqrt(1 - 1.0 / 9)));
  CHECK(g.blocks[g.constraints[0].slack_block].name == "far.slack");
  CHECK(MaxNominalResidual(g) < 1e-12);
  // Inequalities never change the DOF count: two free points, 5 rigid-body + 1 internal.
  const DofReport r = AnalyzeDof(g, g.nominal);
  CHECK(r.dof == 6);
  CHECK(r.rigid_body == 5);
  CHECK(r.internal == 1);
}

TEST_CASE("dsl: a child without a pose is placed by its joint (URDF convention)", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
units: {angle: deg}
components:
  base: {pose: {xyz: [1, 2, 3], rpy: [0, 0, 90]}, points: {o: [0, 0, 0]}}
  arm: {points: {tip: [0.5, 0, 0]}}
joints:
  j:
    type: revolute
    parent: base
    child: arm
    origin: {xyz: [0.1, 0, 0]}
    axis: [0, 0, 1]
    position: 30
)yaml");
  const Rigid3d arm = g.nominal.poses[g.blocks[g.components[1].block].index];
  const Rigid3d expected = Rigid3d::FromXyzRpy({1, 2, 3}, {0, 0, M_PI / 2}) *
                           Rigid3d::FromXyzRpy({0.1, 0, 0}, {0, 0, M_PI / 6});
  CHECK((arm.translation - expected.translation).norm() < 1e-12);
  CHECK(arm.rotation.angularDistance(expected.rotation) < 1e-12);
  CHECK(MaxNominalResidual(g) < 1e-12);
  CHECK(g.joints[0].nominal_position == Approx(M_PI / 6));
}

TEST_CASE("dsl: a child with a pose keeps it; the joint adapts its child frame", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
components:
  box: {points: {c: [0, 0, 0]}}
  lid: {pose: {xyz: [0, 0.25, 0.2]}, points: {l: [0, -0.25, 0]}}
joints:
  hinge: {type: revolute, parent: box, child: lid, origin: {xyz: [0, 0.25, 0.2]}, axis: [1, 0, 0],
          limits: ["-10 deg", "100 deg"]}
)yaml");
  const Rigid3d lid = g.nominal.poses[g.blocks[g.components[1].block].index];
  CHECK((lid.translation - Eigen::Vector3d(0, 0.25, 0.2)).norm() < 1e-12);
  CHECK(g.joints[0].limit_constraint >= 0);
  CHECK(g.constraints[g.joints[0].limit_constraint].name == "hinge_limit");
  CHECK(MaxNominalResidual(g) < 1e-12);
  CHECK(AnalyzeDof(g, g.nominal).dof == 7);
}

TEST_CASE("dsl: includes merge with a prefix, relative to the including file", "[dsl]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/planar-arm.yaml"));
  CHECK(g.FindComponent("l1_link") >= 0);
  CHECK(g.FindComponent("l3_link") >= 0);
  CHECK(g.FindComponent("link") < 0);
  // Each link is placed by its joint: the wrist's child starts where the elbow's link ends.
  const Component& l3 = g.components[g.FindComponent("l3_link")];
  const Component& l2 = g.components[g.FindComponent("l2_link")];
  const Rigid3d p2 = g.nominal.poses[g.blocks[l2.block].index];
  const Rigid3d p3 = g.nominal.poses[g.blocks[l3.block].index];
  CHECK((p3.translation - p2 * Eigen::Vector3d(0.25, 0, 0)).norm() < 1e-12);
}

TEST_CASE("dsl: quaternions and axes are dimensionless, whatever the length unit", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
units: {length: mm}
components:
  a: {pose: {xyz: [100, 0, 0], quaternion: [0.9238795325112867, 0, 0, 0.3826834323650898]}}
  b: {points: {p: [10, 0, 0]}}
joints:
  j: {type: prismatic, parent: a, child: b, axis: [0, 0, 2]}
)yaml");
  const Rigid3d a = g.nominal.poses[0];
  CHECK(a.translation.x() == Approx(0.1));
  CHECK(a.rotation.angularDistance(
            Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()))) < 1e-9);
  CHECK((g.joints[0].axis - Eigen::Vector3d::UnitZ()).norm() < 1e-12);
}

TEST_CASE("dsl: include takes a single mapping too", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
include: {file: parts/planar-link.yaml, prefix: only_}
)yaml");
  CHECK(g.FindComponent("only_link") == 0);
}

TEST_CASE("dsl: other formats come in through include handlers (the URDF hook)", "[dsl]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "cfuse_include_handler_test";
  fs::create_directories(dir);
  std::ofstream(dir / "robot.fake") << "anything the importer reads\n";
  std::ofstream(dir / "broken.fake") << "\n";
  LoadOptions options;
  std::vector<std::string> asked;
  options.include_handlers[".fake"] = [&](const std::string& path, const SourceLocation& where) {
    asked.push_back(path);
    if (path.find("broken") != std::string::npos) {
      throw InputError(SourceLocation(path, 0, 0, "link 'base'"), "made-up importer error");
    }
    CHECK(where.line == 3);
    ModelBuilder b("robot", path);
    const int base = b.AddRigidComponent("base", Rigid3d(), SourceLocation(path));
    b.AddFeaturePoint(base, "origin", Eigen::Vector3d::Zero(), SourceLocation(path));
    return std::move(b).Build();
  };
  const ConstraintGraph g = LoadModelFromString(R"yaml(
include:
  - {file: robot.fake, prefix: r_}
points: {marker: [0, 0, 0.1]}
constraints:
  - distance(r_base.origin, marker) == nominal
)yaml",
                                                "model.yaml", dir.string(), options);
  REQUIRE(asked.size() == 1);
  CHECK(asked[0] == (dir / "robot.fake").lexically_normal().string());
  CHECK(g.FindComponent("r_base") == 0);
  CHECK(g.Describe(g.constraints[0]) == "distance(r_base.origin, marker) == 0.1 m");

  try {
    LoadModelFromString("include: broken.fake\n", "model.yaml", dir.string(), options);
    FAIL("the importer's error was swallowed");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) == (dir / "broken.fake").lexically_normal().string() +
                                       ": link 'base': error: made-up importer error");
  }
}

TEST_CASE("dsl: a cycle of joints names a joint on the cycle", "[dsl]") {
  try {
    Load(R"yaml(
components: {a: {}, b: {}, c: {}}
joints:
  j0: {type: fixed, parent: b, child: c}
  j1: {type: fixed, parent: a, child: b}
  j2: {type: fixed, parent: b, child: a}
)yaml");
    FAIL("a cycle was accepted");
  } catch (const InputError& e) {
    const std::string m = e.message();
    CHECK((m == "joint 'j1' is part of a cycle of joints" ||
           m == "joint 'j2' is part of a cycle of joints"));
  }
}

TEST_CASE("dsl: fixed forms", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
components:
  a: {pose: {xyz: [1, 0, 0]}, points: {x: [0, 0, 0], y: [0, 1, 0]}}
  b: {points: {z: [0, 0, 1]}}
points: {p: [0, 0, 2]}
fixed:
  - a
  - {component: b, fix: orientation}
  - {point: p, at: [0, 0, 2]}
  - {point: b.z}
)yaml");
  CHECK(g.constraints.size() == 4);
  CHECK(g.constraints[0].kind_name == "fixed pose");
  CHECK(g.constraints[0].kind == ConstraintKind::kFixed);
  CHECK(g.constraints[0].fixed_pose.has_value());
  CHECK(g.constraints[0].residual->dimension() == 6);
  CHECK(g.constraints[1].kind_name == "fixed orientation");
  CHECK_FALSE(g.constraints[1].fixed_pose.has_value());
  CHECK(g.constraints[1].residual->dimension() == 3);
  CHECK(g.constraints[2].kind_name == "fixed point");
  CHECK(g.constraints[3].name == "fixed_b_z");
  CHECK(MaxNominalResidual(g) < 1e-12);
  const DofReport r = AnalyzeDof(g, g.nominal);
  CHECK(r.dof == 0);
}

TEST_CASE("dsl: constraints are named c<index> unless named", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
points: {a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0], d: [1, 1, 0]}
constraints:
  - distance(a, b) == nominal
  - {name: square, expr: "perpendicular(b - a, c - a)"}
  - coplanar(a, b, c, d)
)yaml");
  CHECK(g.constraints[0].name == "c1");
  CHECK(g.constraints[1].name == "square");
  CHECK(g.constraints[2].name == "c3");
  CHECK(g.constraints[2].kind_name == "coplanar");
  // Not the name of a point: messages would name two things alike.
  const ConstraintGraph h = Load(R"yaml(
points: {c1: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0]}
constraints:
  - distance(c1, b) == nominal
  - distance(c1, c) == nominal
)yaml");
  CHECK(h.constraints[0].name == "constraint_1");
  CHECK(h.constraints[1].name == "c2");
}

TEST_CASE("dsl: a bare point name resolves to the unique feature point", "[dsl]") {
  const ConstraintGraph g = Load(R"yaml(
components:
  a: {points: {tip: [1, 0, 0]}}
points: {p: [0, 0, 0]}
constraints:
  - distance(tip, p) == 1 m
  - distance(a.tip, p) == 1 m
)yaml");
  CHECK(g.Describe(g.constraints[0]) == "distance(a.tip, p) == 1 m");
  CHECK(g.Describe(g.constraints[1]) == "distance(a.tip, p) == 1 m");
}

}  // namespace
}  // namespace cfuse
