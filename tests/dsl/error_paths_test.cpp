// Error paths of the dsl's readers that the other tests leave out (issue 8): camera objects,
// ROS camera_info, measurement labels, joint-value entries, the model writer, and an include
// whose name the file system refuses; each an InputError at its file, line and column.
// (Model files: tests/dsl/bad_input_test.cpp and tests/data/bad/.)
#include <catch2/catch.hpp>
#include <string>

#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/dsl/model_writer.h"
#include "cfuse/dsl/pose_reader.h"
#include "cfuse/kernel/error.h"
#include "cli/command_support.h"
#include "test_util.h"

namespace cfuse {
namespace {

TEST_CASE("error paths: camera objects and ROS camera_info files", "[dsl][errors]") {
  const std::string ros_tail =
      "distortion_model: plumb_bob\n"
      "distortion_coefficients: {rows: 1, cols: 5, data: [0, 0, 0, 0, 0]}\n";
  const std::string ros_rows =
      "image_width: 640\nimage_height: 480\ncamera_matrix: {rows: 2.5, "
      "cols: 3, data: [800, 0, 320, 0, 800, 240, 0, 0, 1]}\n" +
      ros_tail;
  const testing::BadCase cases[] = {
      {"model: orthographic\nscale: 2000\nfx: 800\ncx: 320\ncy: 240\nwidth: 640\nheight: 480\n", 3,
       5, "an orthographic camera has no 'fx'"},
      {"fx: 800\nfy: 800\nscale: 2\ncx: 320\ncy: 240\nwidth: 640\nheight: 480\n", 3, 8,
       "a pinhole camera has no 'scale' (use fx and fy)"},
      {"model: orthographic\nscale: -2\ncx: 320\ncy: 240\nwidth: 640\nheight: 480\n", 2, 8,
       "camera scale must be positive"},
      {"fx: 800\nfy: 800\ncx: 5000\ncy: 240\nwidth: 640\nheight: 480\n", 3, 5,
       "the principal point cx = 5000 is outside [-640, 1280]"},
      {"fx: 800\nfy: 800\ncx: 320\ncy: -900\nwidth: 640\nheight: 480\n", 4, 5,
       "the principal point cy = -900 is outside [-480, 960]"},
      {ros_rows.c_str(), 3, 23, "camera_matrix rows must be a whole number, got 2.5"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* file) { return ReadCameraFromString(text, file); });
}

TEST_CASE("error paths: an empty label, a joint value without its value", "[dsl][errors]") {
  const testing::BadCase labels[] = {
      {"points:\n  - {xyz: [1, 2, 3], sigma: 0.1, label: ''}\n", 2, 41, "points[0] label is empty"},
  };
  testing::ExpectRefused(
      std::begin(labels), std::end(labels),
      [](const char* text, const char* file) { return ReadMeasurementsFromString(text, file); });
  const testing::BadCase joints[] = {
      {"shoulder: 0.5\nelbow: {sigma: 0.1}\n", 2, 8, "joint 'elbow' needs 'value'"},
  };
  testing::ExpectRefused(
      std::begin(joints), std::end(joints),
      [](const char* text, const char* file) { return ReadJointValuesFromString(text, file); });
}

TEST_CASE("error paths: a model with constraints other than joints is not written as a model",
          "[dsl][errors]") {
  const std::string lamp = testing::SourcePath("examples/lamp.yaml");
  try {
    WriteModel(LoadModel(lamp));
    FAIL("written");
  } catch (const InputError& e) {
    // At the first such constraint, where the model defines it.
    CHECK(e.where().file == lamp);
    CHECK(e.where().line == 45);
    CHECK(e.where().column == 5);
    CHECK_THAT(e.message(), Catch::Matchers::StartsWith("cannot write constraint 'c1' (distance "
                                                        "==) as a model file: only joints"));
  }
}

TEST_CASE("error paths: an include the file system cannot even look up", "[dsl][errors]") {
  // A name longer than the file system allows: stat fails with ENAMETOOLONG, which
  // std::filesystem::exists threw as an internal error (status 3) before.
  const std::string name = std::string(5000, 'a') + ".urdf";
  try {
    LoadModelFromString("include: " + name + "\npoints: {p: [0, 0, 0]}\n", "long.yaml", ".", [] {
      LoadOptions options;
      options.include_handlers[".urdf"] = [](const std::string&, const SourceLocation&) {
        FAIL("the handler is not reached");
        return ConstraintGraph{};
      };
      return options;
    }());
    FAIL("loaded");
  } catch (const InputError& e) {
    CHECK(e.where().file == "long.yaml");
    CHECK(e.where().line == 1);
    CHECK(e.where().column == 10);
    CHECK_THAT(e.message(), Catch::Matchers::StartsWith("cannot open '" + name.substr(0, 100)));
    CHECK_THAT(e.message(), Catch::Matchers::EndsWith("File name too long"));
  }
}

TEST_CASE("error paths: JSON output survives a model name that is not UTF-8", "[dsl][errors]") {
  // A model is named after its file, whose name may be Latin-1; nlohmann::json threw on it.
  const nlohmann::json json = {{"name", std::string("caf\xE9")}};
  CHECK(cli::JsonText(json, -1) == "{\"name\":\"caf\xEF\xBF\xBD\"}");
}

}  // namespace
}  // namespace cfuse
