// `cfuse render --style` through RunRender (cli/image_commands.h): the realistic style of one
// pose and of a sequence, with photographs given; an unknown style, and photographs for the
// plain style, refused with status 2 and nothing written. (Beside the renderer's own tests; it
// runs in cli_test, which links the command line.)
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "cli/image_commands.h"
#include "test_util.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

TEST_CASE("cli: render --style realistic, and bad styles refused", "[cli][render]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_render_style_cli_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path camera = dir / "camera.json";
  std::ofstream(camera) << R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640,
                               "height": 480})";
  cv::Mat photograph(120, 160, CV_8U);
  cv::randu(photograph, 0, 255);
  cv::imwrite((dir / "photograph.png").string(), photograph);

  RenderCommandOptions o;
  o.model = testing::SourcePath("examples/hinged-box.yaml");
  o.camera = camera.string();
  o.sequence = "hand";
  o.frames = 2;
  o.style = "realistic";
  o.photographs = {(dir / "photograph.png").string()};
  o.output = (dir / "frames").string();
  std::ostringstream out, err;
  REQUIRE(RunRender(o, out, err) == 0);
  CHECK_THAT(out.str(), Catch::Matchers::Contains("sequence 'hand' (realistic): 2 frames"));
  CHECK(fs::exists(dir / "frames" / "frame_00001.png"));

  // One pose: the sequence's first.
  o.sequence.clear();
  o.pose = (dir / "frames" / "init.json").string();
  o.output = (dir / "one.png").string();
  REQUIRE(RunRender(o, out, err) == 0);
  CHECK(cv::imread(o.output, cv::IMREAD_UNCHANGED).size() == cv::Size(640, 480));

  auto refused = [&](const RenderCommandOptions& bad, const std::string& message) {
    std::ostringstream bad_out, bad_err;
    CHECK(RunRender(bad, bad_out, bad_err) == 2);
    CHECK_THAT(bad_err.str(), Catch::Matchers::Contains(message));
    CHECK(!fs::exists(bad.output));
  };
  RenderCommandOptions bad = o;
  bad.output = (dir / "bad.png").string();
  bad.style = "photographic";
  refused(bad, "--style 'photographic': the styles are plain and realistic");
  bad.style = "plain";
  refused(bad, "photograph.png: error: --photographs is for --style realistic");
  bad.style = "realistic";
  bad.photographs = {(dir / "missing.png").string()};
  refused(bad, "missing.png: error: cannot open: no such file");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cfuse::cli
