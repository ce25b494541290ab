// The real robots of ../shared/data/urdf (SOURCES.md there): forward kinematics of the imported
// model against DART's link poses, and the DOF the joints imply. Skipped, with a message, where
// that folder is absent (its files are not copied into the project).
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cfuse/constraints/dof.h"
#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/dsl/model_writer.h"
#include "cfuse/importers/urdf.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

// The robots' folder, or "" (with a warning) when it is absent.
std::string RobotsDir() {
  const fs::path dir = fs::path(testing::SourceDir()) / ".." / "shared" / "data" / "urdf";
  if (fs::is_directory(dir)) return dir.lexically_normal().string();
  WARN("skipped: " << dir.string() << " is absent (real robots are not part of the project)");
  return "";
}

std::vector<std::string> Robots(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".urdf") names.push_back(e.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST_CASE("urdf: forward kinematics of every real robot matches DART's to 1e-9", "[importers]") {
  const std::string dir = RobotsDir();
  if (dir.empty()) return;
  const std::vector<std::string> robots = Robots(dir);
  REQUIRE(robots.size() >= 9);
  int compared = 0;
  for (const std::string& robot : robots) {
    const ConstraintGraph g = ImportUrdf(dir + "/" + robot + ".urdf");
    const nlohmann::json reference = ReadJson(dir + "/" + robot + ".fk.json");
    for (const nlohmann::json& config : reference["configurations"]) {
      // Every movable joint's value as DART used it; mimic and locked joints too, which the
      // model accepts when they agree with what they must be.
      std::vector<JointValue> given;
      for (const auto& [name, value] : config["joint_values"].items()) {
        given.push_back({name, value.get<double>(), SourceLocation(robot + ".fk.json")});
      }
      const Values values = ForwardKinematics(g, CompleteJointValues(g, given));
      std::map<std::string, Rigid3d> poses;
      for (const auto& [name, pose] : FramePoses(g, values)) poses[name] = pose;
      for (const auto& [link, expected] : config["link_poses"].items()) {
        INFO(robot << " " << config["name"].get<std::string>() << " link " << link);
        REQUIRE(poses.count(link));
        const Rigid3d& pose = poses[link];
        const auto& xyz = expected["xyz"];
        const auto& wxyz = expected["wxyz"];
        const Eigen::Vector3d t(xyz[0], xyz[1], xyz[2]);
        const Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
        CHECK((pose.translation - t).norm() < 1e-9);
        CHECK(pose.rotation.angularDistance(q) < 1e-9);
        ++compared;
      }
    }
  }
  CHECK(compared > 500);
}

// DOF = 6 (the free base) + movable joints - mimic joints - locked joints. Minitaur's 8 knee
// joints declare no lower or upper limit, which URDF reads as [0, 0]: they cannot move (DART's
// reference keeps them at 0), so the importer merges them like fixed joints and they add no DOF.
TEST_CASE("urdf: check's DOF is what the joints imply, for every real robot", "[importers]") {
  const std::string dir = RobotsDir();
  if (dir.empty()) return;
  for (const std::string& robot : Robots(dir)) {
    const ConstraintGraph g = ImportUrdf(dir + "/" + robot + ".urdf");
    const nlohmann::json reference = ReadJson(dir + "/" + robot + ".fk.json");
    int movable = 0, mimic = 0, locked = 0;
    for (const nlohmann::json& j : reference["joints"]) {
      const std::string type = j["type"];
      if (type == "fixed") continue;
      ++movable;
      if (j.contains("mimic")) ++mimic;
      if (j.contains("range") && j["range"][0] == j["range"][1]) ++locked;
    }
    INFO(robot << ": " << movable << " movable, " << mimic << " mimic, " << locked << " locked");
    const DofReport dof = AnalyzeDof(g, g.nominal);
    REQUIRE(dof.computed);
    CHECK(dof.dof == 6 + movable - mimic - locked);
    CHECK(dof.rigid_body == 6);
  }
}

// `cfuse import` on every real robot: the DSL model it writes has the same DOF and puts every
// link where DART does.
TEST_CASE("urdf: every real robot imported as a DSL model keeps its DOF and kinematics",
          "[importers]") {
  const std::string dir = RobotsDir();
  if (dir.empty()) return;
  for (const std::string& robot : Robots(dir)) {
    const ConstraintGraph g = ImportUrdf(dir + "/" + robot + ".urdf");
    const ConstraintGraph back = LoadModelFromString(WriteModel(g), robot + ".yaml", ".");
    CHECK(AnalyzeDof(back, back.nominal).dof == AnalyzeDof(g, g.nominal).dof);
    const nlohmann::json reference = ReadJson(dir + "/" + robot + ".fk.json");
    for (const nlohmann::json& config : reference["configurations"]) {
      // The DSL has no merged joints: the independent joints only.
      std::vector<JointValue> given;
      for (const auto& [name, value] : config["joint_values"].items()) {
        const int j = back.FindJoint(name);
        if (j >= 0 && !back.joints[j].mimic) given.push_back({name, value.get<double>(), {}});
      }
      const Values values = ForwardKinematics(back, CompleteJointValues(back, given));
      std::map<std::string, Rigid3d> poses;
      for (const auto& [name, pose] : FramePoses(back, values)) poses[name] = pose;
      for (const auto& [link, expected] : config["link_poses"].items()) {
        INFO(robot << " " << config["name"].get<std::string>() << " link " << link);
        REQUIRE(poses.count(link));
        const auto& xyz = expected["xyz"];
        const auto& wxyz = expected["wxyz"];
        CHECK((poses[link].translation - Eigen::Vector3d(xyz[0], xyz[1], xyz[2])).norm() < 1e-9);
        CHECK(poses[link].rotation.angularDistance(
                  Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3])) < 1e-9);
      }
    }
  }
}

}  // namespace
}  // namespace cfuse
