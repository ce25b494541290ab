// The image commands through their Run*() functions: render, then segments and project on
// what it wrote; every kind of bad input exits 2 with its message and writes nothing.
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "cfuse/interp/solve.h"
#include "cli/command_support.h"
#include "cli/commands.h"
#include "cli/image_commands.h"
#include "cli/image_support.h"
#include "test_util.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

struct Scene {
  fs::path dir, camera, pose, image, truth;
};

// The hinged box simulated in front of a 640 x 480 camera (f = 1600), rendered.
Scene MakeScene() {
  Scene s;
  s.dir = fs::temp_directory_path() / "cfuse_image_cli_test";
  fs::create_directories(s.dir);
  s.camera = s.dir / "camera.json";
  std::ofstream(s.camera) << R"({"fx": 1600, "fy": 1600, "cx": 320, "cy": 240, "width": 640,
                                "height": 480})";
  s.pose = s.dir / "truth.json";
  s.image = s.dir / "box.png";
  s.truth = s.dir / "box_truth.json";
  std::ostringstream out, err;
  SimulateCommandOptions sim;
  sim.model = testing::SourcePath("examples/hinged-box.yaml");
  sim.camera = s.camera.string();
  sim.seed = 5;
  sim.sample_joints = true;
  sim.output = (s.dir / "m.json").string();
  sim.truth = s.pose.string();
  REQUIRE(RunSimulate(sim, out, err) == 0);
  RenderCommandOptions render;
  render.model = sim.model;
  render.camera = s.camera.string();
  render.pose = s.pose.string();
  render.output = s.image.string();
  render.truth = s.truth.string();
  REQUIRE(RunRender(render, out, err) == 0);
  return s;
}

nlohmann::json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST_CASE("cli: render, segments and project agree on a rendered box", "[cli]") {
  const Scene s = MakeScene();
  const nlohmann::json truth = ReadJson(s.truth);
  CHECK(truth["width"] == 640);
  CHECK(truth["edges"].size() >= 6);
  CHECK(truth["names"].size() == truth["edges"].size());

  std::ostringstream out, err;
  SegmentsCommandOptions seg;
  seg.image = s.image.string();
  seg.output = (s.dir / "segments.json").string();
  seg.overlay = (s.dir / "segments.png").string();
  REQUIRE(RunSegments(seg, out, err) == 0);
  const nlohmann::json segments = ReadJson(seg.output);
  CHECK(segments["width"] == 640);
  CHECK(segments["height"] == 480);
  CHECK(segments["segments"].size() > 10);
  CHECK(cv::imread(seg.overlay).cols == 640);

  ProjectCommandOptions proj;
  proj.model = testing::SourcePath("examples/hinged-box.yaml");
  proj.camera = s.camera.string();
  proj.pose = s.pose.string();
  proj.output = (s.dir / "edges.json").string();
  proj.overlay = (s.dir / "edges.png").string();
  proj.image = s.image.string();
  REQUIRE(RunProject(proj, out, err) == 0);
  const nlohmann::json edges = ReadJson(proj.output);
  // Every true edge lies on a projected one (the truth is their unoccluded parts).
  for (const nlohmann::json& t : truth["edges"]) {
    const double mx = 0.5 * (t[0].get<double>() + t[2].get<double>());
    const double my = 0.5 * (t[1].get<double>() + t[3].get<double>());
    bool on = false;
    for (const nlohmann::json& e : edges["edges"]) {
      const double ax = e[0], ay = e[1], bx = e[2], by = e[3];
      const double length = std::hypot(bx - ax, by - ay);
      const double distance = std::abs((bx - ax) * (my - ay) - (by - ay) * (mx - ax)) / length;
      on = on || distance < 0.01;
    }
    CHECK(on);
  }
  // Each detector by name, and a region of interest.
  for (const char* detector : {"lowe", "canny", "lsd"}) {
    seg = SegmentsCommandOptions{};
    seg.image = s.image.string();
    seg.detector = detector;
    seg.roi = "100,50,400,300";
    std::ostringstream json;
    REQUIRE(RunSegments(seg, json, err) == 0);
    // Named: a range-for over a member of a temporary outlives the temporary.
    const nlohmann::json parsed = nlohmann::json::parse(json.str());
    for (const nlohmann::json& x : parsed["segments"]) {
      CHECK(x[0].get<double>() >= 99);
      CHECK(x[2].get<double>() <= 500.5);
    }
  }
}

// Runs a command that must fail with status 2, a message containing `message` and no output.
template <typename Options, typename Run>
void ExpectBadInput(const Options& options, Run run, const std::string& message,
                    const std::vector<fs::path>& not_written) {
  for (const fs::path& p : not_written) fs::remove(p);
  std::ostringstream out, err;
  INFO(err.str());
  CHECK(run(options, out, err) == 2);
  CHECK_THAT(err.str(), Catch::Matchers::Contains(message));
  for (const fs::path& p : not_written) CHECK_FALSE(fs::exists(p));
}

TEST_CASE("cli: the image commands refuse bad input with status 2", "[cli]") {
  const Scene s = MakeScene();
  const fs::path json = s.dir / "out.json", png = s.dir / "out.png";
  auto segments = [&](const std::string& image, const std::string& roi,
                      const std::string& detector) {
    SegmentsCommandOptions o;
    o.image = image;
    o.roi = roi;
    o.detector = detector;
    o.output = json.string();
    o.overlay = png.string();
    return o;
  };
  // Images: missing, a directory, empty, not an image, 16-bit, float.
  ExpectBadInput(segments((s.dir / "none.png").string(), "", "lowe"), RunSegments,
                 "none.png: error: cannot open: no such file", {json, png});
  ExpectBadInput(segments(s.dir.string(), "", "lowe"), RunSegments, "it is a directory",
                 {json, png});
  std::ofstream(s.dir / "empty.png").close();
  ExpectBadInput(segments((s.dir / "empty.png").string(), "", "lowe"), RunSegments,
                 "empty.png: error: the file is empty", {json, png});
  std::ofstream(s.dir / "text.png") << "not a picture\n";
  ExpectBadInput(segments((s.dir / "text.png").string(), "", "lowe"), RunSegments,
                 "text.png: error: cannot read the image", {json, png});
  cv::imwrite((s.dir / "deep.png").string(), cv::Mat(20, 30, CV_16U, cv::Scalar(1000)));
  ExpectBadInput(segments((s.dir / "deep.png").string(), "", "lowe"), RunSegments,
                 "deep.png: error: the image has 16-bit samples", {json, png});
  cv::imwrite((s.dir / "float.tiff").string(), cv::Mat(20, 30, CV_32F, cv::Scalar(0.5)));
  ExpectBadInput(segments((s.dir / "float.tiff").string(), "", "lowe"), RunSegments,
                 "the image has float samples", {json, png});
  // Regions of interest outside the image, or not four numbers; an unknown detector.
  for (const char* roi : {"600,0,100,100", "0,0,0,10", "-1,0,10,10", "0,400,10,100"}) {
    ExpectBadInput(segments(s.image.string(), roi, "lowe"), RunSegments,
                   "is not inside the 640 x 480 image", {json, png});
  }
  for (const char* roi : {"1,2,3", "a,b,c,d", "1,2,3,4,5", "1.5,2,3,4"}) {
    ExpectBadInput(segments(s.image.string(), roi, "lowe"), RunSegments,
                   "expected x,y,w,h, four whole numbers", {json, png});
  }
  ExpectBadInput(segments(s.image.string(), "", "hough"), RunSegments,
                 "--detector 'hough': the detectors are lowe, canny and lsd", {json, png});

  // project: a pose file without the lid, a camera without a size, an overlay without its
  // image, an image of another size.
  auto project = [&](const fs::path& pose, const fs::path& camera, const std::string& image) {
    ProjectCommandOptions o;
    o.model = testing::SourcePath("examples/hinged-box.yaml");
    o.camera = camera.string();
    o.pose = pose.string();
    o.output = json.string();
    o.overlay = png.string();
    o.image = image;
    return o;
  };
  std::ofstream(s.dir / "box_only.json")
      << R"({"components": {"box": {"position": [0, 0, 1], "quaternion": [1, 0, 0, 0]}}})";
  ExpectBadInput(project(s.dir / "box_only.json", s.camera, s.image.string()), RunProject,
                 "box_only.json: error: no pose for component 'lid'", {json, png});
  std::ofstream(s.dir / "sizeless.json") << R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240})";
  ExpectBadInput(project(s.pose, s.dir / "sizeless.json", s.image.string()), RunProject,
                 "sizeless.json", {json, png});
  ExpectBadInput(project(s.pose, s.camera, ""), RunProject, "--overlay draws on an image",
                 {json, png});
  cv::imwrite((s.dir / "small.png").string(), cv::Mat(100, 100, CV_8U, cv::Scalar(0)));
  ExpectBadInput(project(s.pose, s.camera, (s.dir / "small.png").string()), RunProject,
                 "the image is 100 x 100, the camera's 640 x 480", {json, png});

  // render: a camera with distortion.
  std::ofstream(s.dir / "distorted.json")
      << R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480,
            "dist": [-0.2, 0.05, 0, 0, 0]})";
  RenderCommandOptions r;
  r.model = testing::SourcePath("examples/hinged-box.yaml");
  r.camera = (s.dir / "distorted.json").string();
  r.pose = s.pose.string();
  r.output = png.string();
  r.truth = json.string();
  ExpectBadInput(r, RunRender, "distorted.json: error: the renderer draws undistorted images",
                 {json, png});
}

// ViSP's files for project: its tracker settings' camera, which gives no size, takes the image's;
// its `.pos` pose of the object places every component of a model rigidly.
TEST_CASE("cli: a ViSP .pos places every component; a ViSP camera takes --image's size", "[cli]") {
  const Scene s = MakeScene();
  const ConstraintGraph box = LoadAnyModel(testing::SourcePath("examples/hinged-box.yaml"));
  REQUIRE(box.components.size() == 2);
  // camera_from_object: 0.4 rad about (1, 2, 2)/3, then 1.5 m ahead.
  const Eigen::Vector3d t(0.05, -0.1, 1.5), theta_u = 0.4 * Eigen::Vector3d(1, 2, 2) / 3;
  const fs::path pos = s.dir / "box.0.pos";
  std::ofstream(pos) << fmt::format("{:.17g}\n{:.17g}\n{:.17g}\n{:.17g}\n{:.17g}\n{:.17g}\n", t.x(),
                                    t.y(), t.z(), theta_u.x(), theta_u.y(), theta_u.z());
  const Values placed = PosedModel(box, pos.string());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 2) / 3).toRotationMatrix();
  for (size_t c = 0; c < box.components.size(); ++c) {
    INFO(box.components[c].name);
    REQUIRE(box.components[c].points.size() >= 4);
    for (size_t f = 0; f < box.components[c].points.size(); ++f) {
      const Eigen::Vector3d nominal =
          ModelPoint(box, box.nominal, static_cast<int>(c), static_cast<int>(f));
      const Eigen::Vector3d moved =
          ModelPoint(box, placed, static_cast<int>(c), static_cast<int>(f));
      CHECK((moved - (R * nominal + t)).norm() < 1e-12);
    }
  }

  // The scene's camera as ViSP's tracker settings write it: no size, which --image gives.
  const fs::path conf = s.dir / "tracker.xml";
  std::ofstream(conf) << "<?xml version=\"1.0\"?>\n<conf>\n  <ecm><sample><step>4</step></sample>"
                         "</ecm>\n  <camera>\n    <u0>320</u0>\n    <v0>240</v0>\n"
                         "    <px>1600</px>\n    <py>1600</py>\n  </camera>\n</conf>\n";
  auto project = [&](const fs::path& camera, const std::string& image, const fs::path& output) {
    ProjectCommandOptions o;
    o.model = testing::SourcePath("examples/hinged-box.yaml");
    o.camera = camera.string();
    o.pose = s.pose.string();
    o.image = image;
    o.output = output.string();
    std::ostringstream out, err;
    const int status = RunProject(o, out, err);
    INFO(err.str());
    return status;
  };
  REQUIRE(project(s.camera, "", s.dir / "cfuse_camera.json") == 0);
  REQUIRE(project(conf, s.image.string(), s.dir / "visp_camera.json") == 0);
  const nlohmann::json cfuse_edges = ReadJson(s.dir / "cfuse_camera.json");
  const nlohmann::json visp_edges = ReadJson(s.dir / "visp_camera.json");
  CHECK(visp_edges["width"] == 640);
  CHECK(visp_edges["height"] == 480);
  CHECK(visp_edges["edges"].size() >= 6);
  CHECK(visp_edges == cfuse_edges);
  // Without an image there is no size to clip to.
  const fs::path none = s.dir / "none.json";
  ExpectBadInput(
      [&] {
        ProjectCommandOptions o;
        o.model = testing::SourcePath("examples/hinged-box.yaml");
        o.camera = conf.string();
        o.pose = s.pose.string();
        o.output = none.string();
        return o;
      }(),
      RunProject,
      "tracker.xml: error: the camera gives no image size (width and height) to clip the edges "
      "to: give --image, whose size it then takes",
      {none});
}

}  // namespace
}  // namespace cfuse::cli
