// `cfuse track` and `cfuse render --sequence` through their Run*() functions: a rendered
// sequence tracked from image files, a directory and a video, its track file against the true
// one; and every kind of bad input: unreadable frames (reported, skipped, status 2 after the
// rest is written), a camera of another size, an empty glob, a far-off start (status 1, every
// frame lost), a bad sequence name or output directory.
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "cfuse/dsl/pose_reader.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/vision/depth_file.h"
#include "cli/image_commands.h"
#include "cli/track_command.h"
#include "test_util.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

struct Sequence {
  fs::path dir, camera, frames;
  std::string model = testing::SourcePath("examples/hinged-box.yaml");
};

// The hinged box's (or `model`'s) steady sequence, 24 frames, rendered by `cfuse render
// --sequence`.
Sequence MakeSequence(const std::string& name, const std::string& model = "") {
  Sequence s;
  if (!model.empty()) s.model = model;
  s.dir = fs::temp_directory_path() / ("cfuse_track_cli_test_" + name);
  fs::remove_all(s.dir);
  fs::create_directories(s.dir);
  s.camera = s.dir / "camera.json";
  std::ofstream(s.camera) << R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640,
                                "height": 480})";
  s.frames = s.dir / "frames";
  RenderCommandOptions render;
  render.model = s.model;
  render.camera = s.camera.string();
  render.sequence = "steady";
  render.frames = 24;
  render.output = s.frames.string();
  std::ostringstream out, err;
  REQUIRE(RunRender(render, out, err) == 0);
  return s;
}

std::vector<std::vector<std::string>> ReadCsv(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> row;
    std::stringstream fields(line);
    for (std::string f; std::getline(fields, f, ',');) row.push_back(f);
    rows.push_back(row);
  }
  return rows;
}

TrackCommandOptions Options(const Sequence& s) {
  TrackCommandOptions o;
  o.model = s.model;
  o.camera = s.camera.string();
  o.images = (s.frames / "frame_*.png").string();
  o.init = (s.frames / "init.json").string();
  o.output = (s.dir / "track.csv").string();
  return o;
}

// The largest distance between the tracked and the true box origin over the verified rows.
double WorstBoxError(const std::vector<std::vector<std::string>>& track,
                     const std::vector<std::vector<std::string>>& truth) {
  double worst = 0;
  for (size_t r = 1; r < track.size(); ++r) {
    if (track[r][2] != "1") continue;
    const size_t frame = std::stoul(track[r][0]);
    double d2 = 0;
    for (int k = 3; k < 6; ++k) {
      const double d = std::stod(track[r][k]) - std::stod(truth[frame + 1][k]);
      d2 += d * d;
    }
    worst = std::max(worst, std::sqrt(d2));
  }
  return worst;
}

TEST_CASE("cli: render --sequence, then track it from a glob, with overlays", "[cli][track]") {
  const Sequence s = MakeSequence("glob");
  CHECK(fs::exists(s.frames / "frame_00023.png"));
  CHECK(fs::exists(s.frames / "init.json"));
  CHECK_FALSE(fs::exists(s.frames.string() + ".partial"));
  TrackCommandOptions o = Options(s);
  o.overlay = (s.dir / "overlay").string();
  std::ostringstream out, err;
  REQUIRE(RunTrack(o, out, err) == 0);
  CHECK_THAT(out.str(), Catch::Contains("24 frames: 24 verified (100.0 %)"));
  CHECK_THAT(out.str(), Catch::Contains("time per frame: median"));
  const auto track = ReadCsv(o.output);
  const auto truth = ReadCsv(s.frames / "truth.csv");
  REQUIRE(track.size() == 25);
  // The truth's columns (frame, time_ms, verified, box's 7, lid's 7, hinge), then the fit.
  REQUIRE(track[0].size() == truth[0].size() + 5);
  CHECK(std::equal(truth[0].begin(), truth[0].end(), track[0].begin()));
  CHECK(track[0].size() == 3 + 7 + 7 + 1 + 5);
  const size_t fit = truth[0].size();
  CHECK(track[0][fit - 1] == "hinge");
  CHECK(track[0][fit] == "support");
  CHECK(track[0][fit + 1] == "sigma_mm");
  CHECK(track[0][fit + 2] == "chi2");
  CHECK(track[0][fit + 3] == "dof");
  CHECK(track[0][fit + 4] == "p_value");
  for (size_t r = 1; r < track.size(); ++r) {
    CHECK(std::stod(track[r][fit]) >= 0.5);      // verified: half the outline
    CHECK(std::stod(track[r][fit + 1]) <= 4.0);  // and determined to 4 mm
    // The residual test accepted the set: its chi-square below the 0.999 quantile.
    const double chi2 = std::stod(track[r][fit + 2]);
    const int dof = std::stoi(track[r][fit + 3]);
    CHECK(dof > 0);
    CHECK(chi2 <= ChiSquareQuantile(0.999, dof));
    CHECK(std::abs(std::stod(track[r][fit + 4]) - (1 - ChiSquareCdf(chi2, dof))) < 1e-3);
  }
  for (size_t r = 1; r < track.size(); ++r) {
    CHECK(track[r][0] == std::to_string(r - 1));
    CHECK(std::stod(track[r][1]) > 0);
  }
  CHECK(WorstBoxError(track, truth) < 0.01);
  CHECK(fs::exists(s.dir / "overlay" / "frame_00000.png"));
  CHECK(cv::imread((s.dir / "overlay" / "frame_00023.png").string()).cols == 640);
}

TEST_CASE("cli: track a directory, and a video, to stdout", "[cli][track]") {
  const Sequence s = MakeSequence("video");
  TrackCommandOptions o = Options(s);
  o.images = s.frames.string();  // the directory: its images, sorted
  o.output.clear();
  std::ostringstream out, err;
  REQUIRE(RunTrack(o, out, err) == 0);
  CHECK_THAT(out.str(), Catch::StartsWith("frame,time_ms,verified,box.x"));
  CHECK_THAT(err.str(), Catch::Contains("24 verified"));

  // The frames as a Motion-JPEG video (OpenCV's own AVI writer: no codec library needed).
  const fs::path video = s.dir / "frames.avi";
  {
    cv::VideoWriter writer(video.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30,
                           cv::Size(640, 480), false);
    REQUIRE(writer.isOpened());
    for (int i = 0; i < 24; ++i) {
      writer.write(
          cv::imread((s.frames / cv::format("frame_%05d.png", i)).string(), cv::IMREAD_GRAYSCALE));
    }
  }
  o.images = video.string();
  o.output = (s.dir / "video.csv").string();
  std::ostringstream out2, err2;
  REQUIRE(RunTrack(o, out2, err2) == 0);
  const auto track = ReadCsv(o.output);
  REQUIRE(track.size() == 25);
  int verified = 0;
  for (size_t r = 1; r < track.size(); ++r) verified += track[r][2] == "1";
  CHECK(verified >= 22);  // JPEG's artefacts cost little
  CHECK(WorstBoxError(track, ReadCsv(s.frames / "truth.csv")) < 0.015);
}

TEST_CASE("cli: an unreadable frame is reported and skipped; the track goes on", "[cli][track]") {
  const Sequence s = MakeSequence("unreadable");
  std::ofstream(s.frames / "frame_00005.png") << "not a PNG";
  TrackCommandOptions o = Options(s);
  std::ostringstream out, err;
  CHECK(RunTrack(o, out, err) == 2);
  CHECK_THAT(err.str(), Catch::Contains("frame_00005.png") && Catch::Contains("skipped"));
  CHECK_THAT(err.str(), Catch::Contains("1 frame(s) could not be read (5)"));
  const auto track = ReadCsv(o.output);
  REQUIRE(track.size() == 24);  // the header and 23 frames
  CHECK(track[5][0] == "4");
  CHECK(track[6][0] == "6");
  CHECK(track[6][2] == "1");  // tracked across the gap
}

TEST_CASE("cli: track refuses bad input with status 2 and writes nothing", "[cli][track]") {
  const Sequence s = MakeSequence("bad");
  auto refused = [&](TrackCommandOptions o, const std::string& message) {
    o.overlay = (s.dir / "overlay_bad").string();
    std::ostringstream out, err;
    CHECK(RunTrack(o, out, err) == 2);
    CHECK_THAT(err.str(), Catch::Contains(message));
    CHECK_FALSE(fs::exists(o.output));
    CHECK_FALSE(fs::exists(o.overlay));
  };
  {
    INFO("a camera of another size");
    const fs::path small = s.dir / "small.json";
    std::ofstream(small) << R"({"fx": 400, "fy": 400, "cx": 160, "cy": 120, "width": 320,
                               "height": 240})";
    TrackCommandOptions o = Options(s);
    o.camera = small.string();
    refused(o, "frame_00000.png: error: the image is 640 x 480, the camera's");
  }
  {
    INFO("a camera without a size");
    const fs::path sizeless = s.dir / "sizeless.json";
    std::ofstream(sizeless) << R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240})";
    TrackCommandOptions o = Options(s);
    o.camera = sizeless.string();
    refused(o, "sizeless.json:1:1: error: the pinhole camera needs 'width'");
  }
  {
    INFO("an empty glob");
    TrackCommandOptions o = Options(s);
    o.images = (s.frames / "nothing_*.png").string();
    refused(o, "no file matches the pattern");
  }
  {
    INFO("a glob in a missing directory");
    TrackCommandOptions o = Options(s);
    o.images = (s.dir / "missing" / "*.png").string();
    refused(o, "no such directory");
  }
  {
    INFO("a missing file");
    TrackCommandOptions o = Options(s);
    o.images = (s.dir / "missing.avi").string();
    refused(o, "no such file or directory");
  }
  {
    INFO("an initial pose missing a component");
    const fs::path init = s.dir / "init_box_only.json";
    std::ofstream(init) << R"({"components": {"box": {"position": [0, 0, 1.3],
                              "quaternion": [1, 0, 0, 0]}}})";
    TrackCommandOptions o = Options(s);
    o.init = init.string();
    refused(o, "no pose for component 'lid'");
  }
}

// A ViSP user's files as they are: the camera of its tracker settings, which gives no image size
// (the first frame's is taken), and the object's pose in a `.pos` file. The track is the one the
// same camera and start in cfuse's own formats give.
TEST_CASE("cli: track with ViSP's tracker settings and a .pos start", "[cli][track]") {
  const Sequence s = MakeSequence("visp", testing::SourcePath("tests/data/cao/cube.cao"));
  const fs::path conf = s.dir / "tracker.xml";
  std::ofstream(conf) << "<?xml version=\"1.0\"?>\n<conf>\n  <camera>\n    <px>800</px>\n"
                         "    <py>800</py>\n    <u0>320</u0>\n    <v0>240</v0>\n  </camera>\n"
                         "</conf>\n";
  const NamedPose start = ReadPoses((s.frames / "init.json").string()).components.at(0);
  const Eigen::AngleAxisd turn(start.pose.rotation);
  const Eigen::Vector3d t = start.pose.translation, theta_u = turn.angle() * turn.axis();
  const fs::path pos = s.dir / "cube.0.pos";
  std::ofstream(pos) << fmt::format("{:.17g}\n{:.17g}\n{:.17g}\n{:.17g}\n{:.17g}\n{:.17g}\n", t.x(),
                                    t.y(), t.z(), theta_u.x(), theta_u.y(), theta_u.z());

  TrackCommandOptions cfuse_files = Options(s);
  TrackCommandOptions visp_files = Options(s);
  visp_files.camera = conf.string();
  visp_files.init = pos.string();
  visp_files.output = (s.dir / "visp.csv").string();
  for (const TrackCommandOptions* o : {&cfuse_files, &visp_files}) {
    std::ostringstream out, err;
    INFO(err.str());
    REQUIRE(RunTrack(*o, out, err) == 0);
    CHECK_THAT(out.str(), Catch::Contains("24 frames: 24 verified (100.0 %)"));
  }
  const auto expected = ReadCsv(cfuse_files.output), track = ReadCsv(visp_files.output);
  REQUIRE(track.size() == 25);
  REQUIRE(expected.size() == 25);
  CHECK(track[0] == expected[0]);
  for (size_t r = 1; r < track.size(); ++r) {
    for (size_t k = 3; k < track[r].size(); ++k) {
      CHECK(std::stod(track[r][k]) == Approx(std::stod(expected[r][k])).margin(1e-5));
    }
  }
  CHECK(WorstBoxError(track, ReadCsv(s.frames / "truth.csv")) < 0.01);

  // A later frame of another size than the first is skipped: the camera's size is the first's.
  cv::imwrite((s.frames / "frame_00007.png").string(), cv::Mat(240, 320, CV_8U, cv::Scalar(90)));
  std::ostringstream out, err;
  CHECK(RunTrack(visp_files, out, err) == 2);
  CHECK_THAT(err.str(), Catch::Contains("frame_00007.png: error: the image is 320 x 240, the first "
                                        "frame's 640 x 480 (the camera, " +
                                        conf.string() + ", gives no size): skipped"));
  CHECK(ReadCsv(visp_files.output).size() == 24);
}

TEST_CASE("cli: a far-off start is lost, then the box is detected and tracked right",
          "[cli][track]") {
  const Sequence s = MakeSequence("far");
  const fs::path init = s.dir / "far.json";
  std::ofstream(init) << R"({"components": {
      "box": {"position": [0.3, 0.2, 1.6], "quaternion": [1, 0, 0, 0]},
      "lid": {"position": [0.3, 0.45, 1.8], "quaternion": [1, 0, 0, 0]}}})";
  TrackCommandOptions o = Options(s);
  o.init = init.string();
  std::ostringstream out, err;
  CHECK(RunTrack(o, out, err) == 0);
  // Lost from the wrong start for the two frames the tracker's own re-acquisition gets, then
  // found by detection, and held from then on.
  CHECK_THAT(out.str(), Catch::Contains("22 verified (91.7 %), lost: 0-1"));
  CHECK_THAT(out.str(), Catch::Contains("found by detection with no pose given: frame 2"));
  const auto track = ReadCsv(o.output);
  CHECK(track[1][2] == "0");
  CHECK(track[2][2] == "0");
  CHECK(WorstBoxError(track, ReadCsv(s.frames / "truth.csv")) < 0.01);
}

TEST_CASE("cli: with no start the box is detected in the first frame and tracked", "[cli][track]") {
  const Sequence s = MakeSequence("no_start");
  TrackCommandOptions o = Options(s);
  o.init.clear();
  std::ostringstream out, err;
  CHECK(RunTrack(o, out, err) == 0);
  CHECK_THAT(out.str(), Catch::Contains("24 verified (100.0 %)"));
  CHECK_THAT(out.str(), Catch::Contains("found by detection with no pose given: frame 0"));
  CHECK(WorstBoxError(ReadCsv(o.output), ReadCsv(s.frames / "truth.csv")) < 0.01);
}

TEST_CASE("cli: render --sequence refuses a bad name or a used directory", "[cli][track]") {
  const Sequence s = MakeSequence("render_bad");
  RenderCommandOptions render;
  render.model = s.model;
  render.camera = s.camera.string();
  render.sequence = "sideways";
  render.output = (s.dir / "new").string();
  std::ostringstream out, err;
  CHECK(RunRender(render, out, err) == 2);
  CHECK_THAT(err.str(), Catch::Contains("no standard sequence 'sideways'"));
  CHECK_FALSE(fs::exists(render.output));
  render.sequence = "steady";
  render.output = s.frames.string();  // exists, not empty
  CHECK(RunRender(render, out, err) == 2);
  CHECK_THAT(err.str(), Catch::Contains("exists and is not an empty directory"));
  render.output = (s.dir / "both").string();
  render.pose = (s.frames / "init.json").string();
  CHECK(RunRender(render, out, err) == 2);
  CHECK_THAT(err.str(), Catch::Contains("exclude each other"));
}

}  // namespace
}  // namespace cfuse::cli

namespace cfuse::cli {
namespace {

// `n` raw depth files of 320 x 240 pixels, every one at `depth` (0: none), in `dir`.
void WriteDepthFiles(const fs::path& dir, int n, std::uint16_t depth) {
  fs::create_directories(dir);
  for (int i = 0; i < n; ++i) {
    std::ofstream out(dir / fmt::format("depth_{:04d}.bin", i), std::ios::binary);
    const std::uint32_t header[2] = {240, 320};  // height, width
    out.write(reinterpret_cast<const char*>(header), sizeof header);
    const std::vector<std::uint16_t> raw(320 * 240, depth);
    out.write(reinterpret_cast<const char*>(raw.data()),
              static_cast<std::streamsize>(raw.size() * 2));
  }
}

TEST_CASE(
    "cli: track with depth files: a sensor that saw nothing leaves the edges to decide, "
    "one that saw a wall behind the box refuses every frame",
    "[cli][track]") {
  const Sequence s = MakeSequence("depth");
  const fs::path depth_camera = s.dir / "depth_camera.json";
  std::ofstream(depth_camera) << R"({"fx": 400, "fy": 400, "cx": 160, "cy": 120, "width": 320,
                                     "height": 240})";
  TrackCommandOptions o = Options(s);
  o.depth = (s.dir / "none" / "*.bin").string();
  o.depth_camera = depth_camera.string();
  WriteDepthFiles(s.dir / "none", 24, 0);
  {
    std::ostringstream out, err;
    INFO(err.str());
    CHECK(RunTrack(o, out, err) == 0);
    CHECK_THAT(out.str(), Catch::Contains("24 frames: 24 verified (100.0 %)"));
  }
  // A wall 5 m away where the box stands, 1 m from the camera.
  WriteDepthFiles(s.dir / "wall", 24, 5000);
  o.depth = (s.dir / "wall").string();
  {
    std::ostringstream out, err;
    // (the same frames as above, verified when the sensor saw nothing: the wall refuses them)
    CHECK(RunTrack(o, out, err) == 1);
    CHECK_THAT(out.str(), Catch::Contains("24 frames: 0 verified"));
  }
}

TEST_CASE("cli: track refuses bad depth input with status 2", "[cli][track]") {
  const Sequence s = MakeSequence("bad_depth");
  const fs::path depth_camera = s.dir / "depth_camera.json";
  std::ofstream(depth_camera) << R"({"fx": 400, "fy": 400, "cx": 160, "cy": 120, "width": 320,
                                     "height": 240})";
  WriteDepthFiles(s.dir / "depth", 24, 0);
  TrackCommandOptions good = Options(s);
  good.depth = (s.dir / "depth" / "*.bin").string();
  good.depth_camera = depth_camera.string();
  auto refused = [&](const TrackCommandOptions& o, const std::string& message) {
    std::ostringstream out, err;
    CHECK(RunTrack(o, out, err) == 2);
    CHECK_THAT(err.str(), Catch::Contains(message));
    CHECK_FALSE(fs::exists(o.output));
  };
  TrackCommandOptions o = good;
  o.depth = (s.dir / "depth" / "depth_000*.bin").string();
  refused(o, o.depth + ": error: 10 depth files for 24 frames: one a frame is needed");
  o = good;
  o.depth_distortion = {0.1, 0.2, 0.3};
  refused(o, "--depth-distortion: error: 3 coefficients given, 5 needed (k1, k2, p1, p2, k3)");
  o = good;
  o.depth_scale = 0;
  refused(o, "--depth-scale: error: 0 metres a depth unit: a positive number is needed");
  o = good;
  o.depth_pose = (s.dir / "depth_M_color.txt").string();
  std::ofstream(o.depth_pose) << "1 0 0 0\n0 1 0 0\n0 0 1 0\n";
  refused(o, o.depth_pose + ":3:8: error: a ViSP homogeneous matrix is sixteen numbers");
  o = good;
  o.depth_camera = (s.dir / "missing.json").string();
  refused(o, "missing.json");
  // A depth file cut short: its frame skipped, the rest tracked and written, status 2.
  fs::resize_file(s.dir / "depth" / "depth_0005.bin", 100);
  std::ostringstream out, err;
  CHECK(RunTrack(good, out, err) == 2);
  CHECK_THAT(err.str(), Catch::Contains("depth_0005.bin: error: the file ends before its 320 x 240 "
                                        "depths: skipped, the track goes on"));
  CHECK(ReadCsv(good.output).size() == 24);  // the header and 23 frames
}

TEST_CASE("cli: castel tracked with its depth frames, ViSP's files as they are", "[cli][track]") {
  const fs::path d = "/usr/share/visp-images-data/ViSP-images/mbt-depth/castel";
  if (!fs::is_directory(d)) {
    WARN("visp-images-data is not installed: skipped");
    return;
  }
  TrackCommandOptions o;
  o.model = (d / "chateau.cao").string();
  o.camera = (d / "chateau.xml").string();
  o.images = (d / "castel" / "image_*.pgm").string();
  o.init = (d / "chateau.0.pos").string();
  o.depth = (d / "castel" / "depth_image_*.bin").string();
  o.depth_camera = (d / "chateau_depth.xml").string();
  o.depth_pose = (d / "depth_M_color.txt").string();
  o.depth_scale = kCastelMetresPerUnit;
  const DepthIntrinsics sr300 = CastelDepthIntrinsics();
  o.depth_distortion.assign(sr300.coefficients.begin(), sr300.coefficients.end());
  const fs::path dir = fs::temp_directory_path() / "cfuse_track_cli_test_castel_depth";
  fs::create_directories(dir);
  o.output = (dir / "track.csv").string();
  std::ostringstream out, err;
  INFO(err.str());
  REQUIRE(RunTrack(o, out, err) == 0);
  // Against ViSP's track with edges and depth (tests/data/visp/castel_reference.csv).
  const auto track = ReadCsv(o.output),
             reference = ReadCsv(testing::SourcePath("tests/data/visp/castel_reference.csv"));
  REQUIRE(track.size() == 31);
  REQUIRE(reference.size() == 31);
  std::vector<double> mm;
  for (size_t r = 1; r < track.size(); ++r) {
    if (track[r][2] != "1") continue;
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double e = std::stod(track[r][3 + k]) - std::stod(reference[r][1 + k]);
      d2 += e * e;
    }
    mm.push_back(1000 * std::sqrt(d2));
  }
  CHECK(mm.size() >= 28);
  std::sort(mm.begin(), mm.end());
  CHECK(mm[mm.size() / 2] <= 3);
  CHECK(mm.back() <= 8);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cfuse::cli
