// The subcommands through their Run*() functions: outputs, exit statuses, no partial files.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <fmt/format.h>

#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/interp/solve.h"
#include "cli/command_support.h"
#include "cli/commands.h"
#include "test_util.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

TEST_CASE("cli: check --json reports the designed DOF of every example", "[cli]") {
  const std::vector<std::tuple<const char*, int, int, int>> examples = {
      {"examples/lamp.yaml", 11, 6, 5},
      {"examples/scissors.yaml", 7, 6, 1},
      {"examples/hinged-box.yaml", 7, 6, 1},
      {"examples/planar-arm.yaml", 3, 0, 3},
      {"examples/four-bar.yaml", 7, 6, 1},
      {"examples/folding-ruler.yaml", 9, 6, 3},
      {"examples/stewart-platform.yaml", 12, 6, 6},
      {"examples/cabinet.yaml", 8, 6, 2}};
  for (const auto& [file, dof, rigid, internal] : examples) {
    std::ostringstream out, err;
    REQUIRE(RunCheck({testing::SourcePath(file), true, {}}, out, err) == 0);
    CHECK(err.str().empty());
    const nlohmann::json j = nlohmann::json::parse(out.str());
    CHECK(j["dof"]["total"] == dof);
    CHECK(j["dof"]["rigid_body"] == rigid);
    CHECK(j["dof"]["internal"] == internal);
    CHECK(j["violations"].empty());
  }
}

TEST_CASE("cli: check prints the summary and warns about violated constraints", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const fs::path model = dir / "violated.yaml";
  std::ofstream(model) << "points: {a: [0, 0, 0], b: [1, 0, 0]}\nconstraints:\n"
                          "  - name: too_long\n    expr: distance(a, b) == 2 m\n";
  std::ostringstream out, err;
  REQUIRE(RunCheck({model.string(), false, {}}, out, err) == 0);
  CHECK(out.str().find("DOF: 5 (5 rigid-body + 0 internal)") != std::string::npos);
  CHECK(out.str().find(model.string() +
                       ":4:11: warning: constraint 'too_long' "
                       "(distance(a, b) == 2 m) is violated by the nominal geometry") !=
        std::string::npos);
  CHECK(out.str().find("restates") == std::string::npos);  // it repeats nothing

  // One that repeats an earlier constraint with another value: the pair is named.
  std::ofstream(model) << "points: {a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0]}\nconstraints:\n"
                          "  - distance(a, b) == 1 m\n  - distance(a, c) == 1 m\n"
                          "  - {name: too_far, expr: \"distance(a, b) == 2 m\"}\n";
  std::ostringstream out2, err2;
  REQUIRE(RunCheck({model.string(), false, {}}, out2, err2) == 0);
  CHECK(out2.str().find("warning: constraint 'too_far' (distance(a, b) == 2 m) is violated by "
                        "the nominal geometry (largest residual 1); it restates what 'c1' "
                        "(distance(a, b) == 1 m) fixes, which holds there: they contradict each "
                        "other") != std::string::npos);
  std::ostringstream out3, err3;
  REQUIRE(RunCheck({model.string(), true, {}}, out3, err3) == 0);
  CHECK(nlohmann::json::parse(out3.str())["violations"][0]["repeats"] ==
        nlohmann::json::array({"c1"}));
}

TEST_CASE("cli: check warns about a face that is not planar", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const fs::path model = dir / "warped.yaml";
  std::ofstream(model)
      << "components:\n  plate:\n    points: {a: [0, 0, 0], b: [1, 0, 0], c: [1, 1, 0], "
         "d: [0, 1, 0.1]}\n    faces:\n      top: [a, b, c, d]\n";
  std::ostringstream out, err;
  REQUIRE(RunCheck({model.string(), false, {}}, out, err) == 0);
  CHECK(out.str().find(model.string() + ":5:7: warning: face 'top' of 'plate' is not planar") !=
        std::string::npos);
}

TEST_CASE("cli: a model beyond the dense DOF analysis still loads and is summarised", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const fs::path model = dir / "chain.yaml";
  {
    std::ofstream out(model);
    out << "points:\n";
    for (int i = 0; i < 1000; ++i)
      out << "  p" << i << ": [" << i * 0.01 << ", 0, " << (i % 3) * 0.01 << "]\n";
    out << "constraints:\n";
    for (int i = 0; i + 1 < 1000; ++i)
      out << "  - distance(p" << i << ", p" << i + 1 << ") == nominal\n";
  }
  std::ostringstream out, err;
  REQUIRE(RunCheck({model.string(), false, {}}, out, err) == 0);
  CHECK(out.str().find("state dimension: 3000\n") != std::string::npos);
  CHECK(out.str().find("DOF: not computed (the dense rank analysis is limited to a state "
                       "dimension of 2000)") != std::string::npos);
  std::ostringstream json, err2;
  REQUIRE(RunCheck({model.string(), true, {}}, json, err2) == 0);
  CHECK(nlohmann::json::parse(json.str())["dof"].is_null());
}

TEST_CASE("cli: bad input exits with status 2 and one located message", "[cli]") {
  std::ostringstream out, err;
  CHECK(RunCheck({"no/such/model.yaml", false, {}}, out, err) == 2);
  CHECK(err.str() == "no/such/model.yaml: error: cannot open: no such file\n");
  CHECK(out.str().empty());
  std::ostringstream out2, err2;
  CHECK(RunCheck({testing::SourcePath("README.md"), false, {}}, out2, err2) == 2);
  CHECK(err2.str().find("unsupported model format '.md'") != std::string::npos);
}

// `cfuse import`: the model file it writes checks to the same DOF as the URDF; nothing is
// written for a malformed robot.
TEST_CASE("cli: import writes a robot as a model file with the same DOF", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const std::string urdf = testing::SourcePath("tests/data/urdf/arm.urdf");
  const fs::path model = dir / "arm.yaml";
  fs::remove(model);
  std::ostringstream out, err;
  REQUIRE(RunImport({urdf, model.string()}, out, err) == 0);
  CHECK(err.str().empty());
  std::ostringstream a, b, e1, e2;
  REQUIRE(RunCheck({urdf, true, {}}, a, e1) == 0);
  REQUIRE(RunCheck({model.string(), true, {}}, b, e2) == 0);
  CHECK(nlohmann::json::parse(a.str())["dof"]["total"] == 10);
  CHECK(nlohmann::json::parse(b.str())["dof"]["total"] == 10);

  const fs::path bad_urdf = dir / "bad.urdf", bad_model = dir / "bad.yaml";
  std::ofstream(bad_urdf) << "<robot name=\"r\">\n  <link name=\"a\"/>\n  <link name=\"b\"/>\n"
                             "  <joint name=\"j\" type=\"revolute\"><parent link=\"a\"/>"
                             "<child link=\"c\"/></joint>\n</robot>\n";
  fs::remove(bad_model);
  std::ostringstream out2, err2;
  CHECK(RunImport({bad_urdf.string(), bad_model.string()}, out2, err2) == 2);
  CHECK(err2.str() == bad_urdf.string() + ":4:53: joint 'j': error: unknown child link 'c'\n");
  CHECK_FALSE(fs::exists(bad_model));
}

// `cfuse fk`: every component's and frame's pose and every joint's value; bad joint values are
// refused at their entry, with nothing written.
TEST_CASE("cli: fk writes every link's pose for the joint values", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const std::string urdf = testing::SourcePath("tests/data/urdf/arm.urdf");
  const fs::path joints = dir / "q.json", poses = dir / "poses.json";
  std::ofstream(joints) << "{\"shoulder\": 0.5, \"slide\": {\"value\": 0.02}, \"grip_a\": 0.01}\n";
  std::ostringstream out, err;
  INFO(err.str());
  REQUIRE(RunFk({urdf, joints.string(), poses.string()}, out, err) == 0);
  std::ifstream in(poses);
  const nlohmann::json j = nlohmann::json::parse(in);
  for (const char* link :
       {"base", "base_plate", "upper", "fore", "slider", "finger_a", "finger_b", "tool"}) {
    INFO(link);
    CHECK(j["components"].contains(link));
  }
  CHECK(j["joints"]["shoulder"]["value"] == 0.5);
  CHECK(j["joints"]["grip_b"]["value"] == 0.01);  // the mimic
  CHECK(j["joints"]["elbow"]["value"] == 0);
  // upper turns by the plate's 0.3 rad and the shoulder's 0.5 about z.
  const auto& q = j["components"]["upper"]["quaternion"];
  CHECK(std::abs(q[0].get<double>() - std::cos(0.4)) < 1e-12);
  CHECK(std::abs(q[3].get<double>() - std::sin(0.4)) < 1e-12);

  std::ofstream(joints) << "{\"shoulder\": 0.5,\n \"wrist\": 1}\n";
  fs::remove(poses);
  std::ostringstream out2, err2;
  CHECK(RunFk({urdf, joints.string(), poses.string()}, out2, err2) == 2);
  CHECK(err2.str() == joints.string() +
                          ":2:2: joint 'wrist': error: 'wrist' is not a joint of model "
                          "'test_arm'\n");
  CHECK_FALSE(fs::exists(poses));
  std::ofstream(joints) << "{\"shoulder\": \"half\"}\n";
  std::ostringstream out3, err3;
  CHECK(RunFk({urdf, joints.string(), ""}, out3, err3) == 2);
  CHECK(err3.str().find("q.json:1:14: error: joint 'shoulder' must be a number") !=
        std::string::npos);
  CHECK(out3.str().empty());
  // A quoted number is a string: refused, not read as the number.
  std::ofstream(joints) << "{\"shoulder\": \"0.5\"}\n";
  std::ostringstream out4, err4;
  CHECK(RunFk({urdf, joints.string(), ""}, out4, err4) == 2);
  CHECK(err4.str().find("q.json:1:14: error: joint 'shoulder' must be a number, got the string "
                        "\"0.5\"") != std::string::npos);
}

// A URDF's names that model files could not write ('base-link', 'arm.1') stay as the URDF spells
// them in fk's input and output and in measurement labels; the identifier model files use
// ('base_link') is accepted too, and `import` writes that one.
TEST_CASE("cli: a URDF's own link and joint names work as written", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const fs::path urdf = dir / "spelled.urdf", joints = dir / "q_spelled.json",
                 poses = dir / "poses_spelled.json";
  std::ofstream(urdf) << R"(<robot name="spelled">
  <link name="base-link"/>
  <link name="arm.1"/>
  <link name="tool tip"/>
  <joint name="joint-1" type="revolute"><parent link="base-link"/><child link="arm.1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="tip joint" type="fixed"><parent link="arm.1"/><child link="tool tip"/>
    <origin xyz="0.2 0 0"/></joint>
</robot>
)";
  for (const char* name : {"joint-1", "joint_1"}) {
    INFO(name);
    std::ofstream(joints) << fmt::format("{{\"{}\": 0.5}}\n", name);
    std::ostringstream out, err;
    REQUIRE(RunFk({urdf.string(), joints.string(), poses.string()}, out, err) == 0);
    std::ifstream in(poses);
    const nlohmann::json j = nlohmann::json::parse(in);
    CHECK(j["joints"]["joint-1"]["value"] == 0.5);
    CHECK(j["components"].contains("base-link"));
    CHECK(j["components"].contains("arm.1"));
    // A name with a space would break a CSV column or a name=value list: its identifier.
    CHECK(j["components"].contains("tool_tip"));
    const auto& xyz = j["components"]["tool_tip"]["position"];
    CHECK(std::abs(xyz[0].get<double>() - 0.2 * std::cos(0.5)) < 1e-12);
  }
  const ConstraintGraph g = LoadAnyModel(urdf.string());
  CHECK(g.FindComponent("base_link") == g.FindComponent("base-link"));
  CHECK(g.FindFrame("tool tip"));
  const MeasurementSet set = ReadMeasurementsFromString(
      "points:\n  - {xyz: [0, 0, 0.1], sigma: 0.001, label: arm.1.origin}\n"
      "  - {xyz: [0, 0, 0.1], sigma: 0.001, label: arm_1.origin}\n",
      "meas.yaml");
  const std::vector<ResolvedLabel> labels = ResolveLabels(g, set);
  REQUIRE(labels.size() == 2);
  CHECK(labels[0].component == g.FindComponent("arm.1"));
  CHECK(labels[1].component == g.FindComponent("arm.1"));
  std::ofstream(joints) << "{\"joint-1\": 0.5, \"joint_1\": 0.5}\n";
  std::ostringstream out, err;
  CHECK(RunFk({urdf.string(), joints.string(), ""}, out, err) == 2);
  CHECK(err.str().find("joint 'joint_1' is given twice") != std::string::npos);
  // `import` writes identifiers, which a model file can refer to.
  const fs::path model = dir / "spelled.yaml";
  std::ostringstream out2, err2;
  REQUIRE(RunImport({urdf.string(), model.string()}, out2, err2) == 0);
  const ConstraintGraph back = LoadAnyModel(model.string());
  CHECK(back.FindComponent("base_link") >= 0);
  CHECK(back.FindJoint("joint_1") >= 0);
}

TEST_CASE("cli: graph writes dot, atomically", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const fs::path dot = dir / "box.dot";
  fs::remove(dot);
  std::ostringstream out, err;
  REQUIRE(RunGraph({testing::SourcePath("examples/hinged-box.yaml"), dot.string()}, out, err) == 0);
  std::ifstream in(dot);
  std::stringstream content;
  content << in.rdbuf();
  CHECK(content.str().rfind("graph \"hinged file box\" {", 0) == 0);
  CHECK(content.str().find("hinge\\nrevolute") != std::string::npos);
  // No stray temporary file of its own (".box.dot.tmp..."; other tests share the directory and
  // may be writing theirs at the same time).
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    files += entry.path().filename().string().rfind(".box.dot.tmp", 0) == 0;
  CHECK(files == 0);

  // A model error writes nothing; a missing directory is refused.
  const fs::path bad = dir / "bad.dot";
  fs::remove(bad);
  std::ostringstream out2, err2;
  CHECK(RunGraph({"missing.yaml", bad.string()}, out2, err2) == 2);
  CHECK(!fs::exists(bad));
  std::ostringstream out3, err3;
  CHECK(RunGraph({testing::SourcePath("examples/lamp.yaml"), (dir / "nope" / "x.dot").string()},
                 out3, err3) == 2);
  CHECK(err3.str().find("directory") != std::string::npos);
}

TEST_CASE("cli: demo interprets the built-in lamp and writes its picture", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_cli_test";
  fs::create_directories(dir);
  const fs::path picture = dir / "demo.png";
  const fs::path overlays = dir / "demo-track";
  fs::remove(picture);
  std::ostringstream out, err;
  CHECK(RunDemo({picture.string(), overlays.string()}, out, err) == 0);
  CHECK(out.str().find("DOF: 11 (6 rigid-body + 5 internal)") != std::string::npos);
  CHECK(out.str().find("matches: 23 of 23 points right") != std::string::npos);
  // The tracking part: the hinged box through 120 frames, its overlays written.
  CHECK(out.str().find("of 120 frames verified") != std::string::npos);
  CHECK(fs::exists(overlays / "frame_00119.png"));
  CHECK_FALSE(fs::exists(overlays.string() + ".partial"));
  CHECK(err.str().empty());
  // A PNG: its signature, and a picture of some size.
  std::ifstream in(picture, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(bytes.size() > 10000);
  CHECK(bytes.substr(1, 3) == "PNG");

  // A picture that cannot be written: exit status 2, nothing left behind.
  std::ostringstream out2, err2;
  CHECK(RunDemo({(dir / "nope" / "demo.png").string(), ""}, out2, err2) == 2);
  CHECK(err2.str().find("directory") != std::string::npos);
}

}  // namespace
}  // namespace cfuse::cli
