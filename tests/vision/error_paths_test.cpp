// Error paths of the vision library that the other tests leave out (issue 8): OpenCV camera
// files refused by node, and a camera whose image is too large to render (refused, not an
// allocation failure reported as an internal error).
#include <fmt/format.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/error.h"
#include "cfuse/vision/camera_file.h"
#include "cfuse/vision/render.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

// An OpenCV calibration in YAML whose camera_matrix and distortion_coefficients headers are
// given (the lines between the node's tag and its data).
std::string OpenCvYaml(const std::string& k_header, const std::string& d_header) {
  return "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n"
         "camera_matrix: !!opencv-matrix\n" +
         k_header + "   data: [ 800., 0., 320., 0., 800., 240., 0., 0., 1. ]\n" +
         "distortion_coefficients: !!opencv-matrix\n" + d_header +
         "   data: [ 0., 0., 0., 0., 0. ]\n";
}

TEST_CASE("error paths: OpenCV camera files refused at the node", "[vision][errors]") {
  const fs::path dir =
      fs::temp_directory_path() / fmt::format("cfuse_vision_errors_{}", ::getpid());
  fs::create_directories(dir);
  const std::string k = "   rows: 3\n   cols: 3\n   dt: d\n";
  const std::string d = "   rows: 1\n   cols: 5\n   dt: d\n";
  const struct {
    std::string text;
    const char* node;
    const char* message;
  } cases[] = {
      {OpenCvYaml("   rows: 3.5\n   cols: 3\n   dt: d\n", d), "camera_matrix",
       "'rows' must be a whole number"},
      {OpenCvYaml(k, "   rows: 1\n   cols: 5\n   dt: \"3d\"\n"), "distortion_coefficients",
       "must be a matrix of numbers (dt 'd' or 'f'), got dt '3d'"},
  };
  int i = 0;
  for (const auto& c : cases) {
    const std::string path = (dir / fmt::format("camera{}.yml", i++)).string();
    std::ofstream(path) << c.text;
    INFO(c.text);
    REQUIRE(IsOpenCvStorage(path));
    try {
      ReadOpenCvCamera(path);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().file == path);
      CHECK(e.where().line == 0);
      CHECK(e.where().element == c.node);
      CHECK(e.message() == c.message);
      CHECK(std::string(e.what()) == path + ": " + c.node + ": error: " + c.message);
    }
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
}

TEST_CASE("error paths: a camera image too large to render", "[vision][errors]") {
  const ConstraintGraph box = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera camera = testing::Pinhole();
  camera.width = camera.height = 1000000;  // what a camera file may give
  // Bad input, without a file: the caller knows which camera file it read.
  try {
    Render(box, box.nominal, camera);
    FAIL("rendered");
  } catch (const InputError& e) {
    CHECK_FALSE(e.where().known());
    CHECK(e.message() ==
          "the camera's image, 1000000 x 1000000 pixels, is larger than the renderer's limit of "
          "2^28 pixels");
  }
}

}  // namespace
}  // namespace cfuse
