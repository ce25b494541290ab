// `cfuse detect` through RunDetect(): Castle-simu's frame found at its true pose with a JSON
// result usable as `cfuse track --init` and an overlay; an image without the castle (status 1,
// the reason, the result still written); and bad input (status 2, nothing written): an
// unreadable image, an image of another size than the camera, a model without edges.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "cfuse/dsl/pose_reader.h"
#include "cli/detect_command.h"
#include "test_util.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

const fs::path kCastle = "/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu";

fs::path Scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("cfuse_detect_cli_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

DetectCommandOptions Castle(const fs::path& image) {
  DetectCommandOptions o;
  o.model = (kCastle / "Models/chateau.cao").string();
  o.camera = (kCastle / "Config/chateau.xml").string();
  o.image = image.string();
  return o;
}

TEST_CASE("cli detect: Castle-simu's frame found, its result usable as a start", "[cli]") {
  if (!fs::exists(kCastle)) {
    WARN("visp-images-data is not installed: skipped");
    return;
  }
  const fs::path dir = Scratch("found");
  DetectCommandOptions o = Castle(kCastle / "Images/Image_0010.pgm");
  o.output = (dir / "result.json").string();
  o.overlay = (dir / "overlay.png").string();
  std::ostringstream out, err;
  REQUIRE(RunDetect(o, out, err) == 0);
  CHECK(err.str().find("chateau found (1 of 1)") != std::string::npos);
  CHECK(out.str().empty());
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(o.output));
  CHECK(j["found"] == true);
  REQUIRE(j["objects"].size() == 1);
  CHECK(j["objects"][0]["verified"] == true);
  CHECK(j["objects"][0]["outline"]["share"].get<double>() > 0.7);
  CHECK(j["stats"]["junctions"].get<int>() > 0);
  // The castle's covariance: 6 x 6, symmetric, positive on its diagonal.
  const nlohmann::json& cov = j["objects"][0]["covariance"]["chateau"];
  REQUIRE(cov.size() == 6);
  for (int r = 0; r < 6; ++r) {
    CHECK(cov[r][r].get<double>() > 0);
    for (int k = 0; k < 6; ++k) CHECK(cov[r][k].get<double>() == Approx(cov[k][r].get<double>()));
  }
  CHECK(j["objects"][0]["joints"].empty());
  // The true camera pose of frame 10 (Castle-simu's CameraPose/Camera_010.txt).
  std::ifstream truth(kCastle / "CameraPose/Camera_010.txt");
  double m[16];
  for (double& x : m) truth >> x;
  const Eigen::Vector3d t(m[3], m[7], m[11]);
  // The result's components read back as a start, as `cfuse track --init` reads them.
  std::ofstream(dir / "start.json") << j["objects"][0].dump();
  const PoseSet poses = ReadPoses((dir / "start.json").string());
  REQUIRE(poses.components.size() == 1);
  CHECK((poses.components[0].pose.translation - t).norm() < 0.005);
  CHECK(cv::imread(o.overlay).cols == 640);
}

TEST_CASE("cli detect: an image without the object is status 1 with the reason", "[cli]") {
  if (!fs::exists(kCastle)) {
    WARN("visp-images-data is not installed: skipped");
    return;
  }
  const fs::path dir = Scratch("none");
  cv::imwrite((dir / "grey.png").string(), cv::Mat(480, 640, CV_8U, cv::Scalar(100)));
  std::ostringstream out, err;
  REQUIRE(RunDetect(Castle(dir / "grey.png"), out, err) == 1);
  const nlohmann::json j = nlohmann::json::parse(out.str());
  CHECK(j["found"] == false);
  CHECK(j["objects"].empty());
  CHECK(j["why"].get<std::string>().find("no junction") != std::string::npos);
  CHECK(err.str().find("not found") != std::string::npos);
}

TEST_CASE("cli detect: bad input is status 2 with the file named and nothing written", "[cli]") {
  const fs::path dir = Scratch("bad");
  const std::string box = testing::SourcePath("tests/data/cao/file_box.cao");
  std::ofstream(dir / "camera.json") << R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240,
                                            "width": 640, "height": 480})";
  std::ofstream(dir / "broken.png") << "not a picture";
  cv::imwrite((dir / "small.png").string(), cv::Mat(100, 120, CV_8U, cv::Scalar(100)));
  std::ofstream(dir / "bare.yaml") << "name: bare\ncomponents:\n  a:\n    points:\n"
                                      "      p: [0, 0, 0]\n      q: [1, 0, 0]\n";
  auto run = [&](const std::string& model, const std::string& image) {
    DetectCommandOptions o;
    o.model = model;
    o.camera = (dir / "camera.json").string();
    o.image = image;
    o.output = (dir / "result.json").string();
    std::ostringstream out, err;
    const int status = RunDetect(o, out, err);
    CHECK_FALSE(fs::exists(o.output));
    return std::pair{status, err.str()};
  };
  auto [s1, e1] = run(box, (dir / "broken.png").string());
  CHECK(s1 == 2);
  CHECK(e1.find("broken.png") != std::string::npos);
  auto [s2, e2] = run(box, (dir / "small.png").string());
  CHECK(s2 == 2);
  CHECK(e2.find("small.png") != std::string::npos);
  CHECK(e2.find("120 x 100") != std::string::npos);
  auto [s3, e3] = run((dir / "bare.yaml").string(), (dir / "small.png").string());
  CHECK(s3 == 2);
  CHECK(e3.find("no edges") != std::string::npos);
}

}  // namespace
}  // namespace cfuse::cli
