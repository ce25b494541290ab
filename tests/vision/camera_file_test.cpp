// Camera files from the ecosystem: OpenCV calibration files written by cv::FileStorage in YAML,
// XML and JSON, and a ROS camera_info file, read back into cameras that project exactly as
// cv::projectPoints does with the same K and coefficients; every refused OpenCV file with the
// node and message.
#include "cfuse/vision/camera_file.h"

#include <fmt/format.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "cfuse/dsl/measurement_reader.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

// A directory of this test case's own, removed with it (ctest runs test cases in parallel).
struct TempDir {
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() /
             fmt::format("cfuse_camera_file_test_{}_{}", ::getpid(), name)) {
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  fs::path path;
};

// The largest distance, in pixels, between camera.Project and cv::projectPoints with K and the
// coefficients D, over random points in the camera's field of view 0.3-5 m away.
double MaxProjectionDifference(const Camera& camera, const cv::Mat& K, const cv::Mat& D) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> depth(0.3, 5), slope(-0.4, 0.4);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < 500; ++i) {
    const double z = depth(rng);
    points.emplace_back(slope(rng) * z, slope(rng) * z * 0.75, z);
  }
  std::vector<cv::Point2d> expected;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, expected);
  double worst = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d uv =
        camera.Project(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
    worst = std::max(worst, (uv - Eigen::Vector2d(expected[i].x, expected[i].y)).norm());
  }
  return worst;
}

const cv::Matx33d kK(812.4719238281250, 0, 321.87614440917969, 0, 810.9337158203125,
                     238.41217041015625, 0, 0, 1);

// OpenCV's coefficients k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 tau_x tau_y: a lens with strong
// barrel distortion, the rational and thin-prism terms small, no tilt.
const double kDistortion[14] = {-0.28,  0.09,   1.2e-3, -6.4e-4, -0.012, 0.05, 0.011,
                                0.0021, 1.5e-3, -2e-4,  5e-4,    1e-4,   0,    0};

TEST_CASE("OpenCV camera files: YAML, XML and JSON project as cv::projectPoints", "[vision]") {
  const TempDir temp("round_trip");
  const fs::path& dir = temp.path;
  for (const char* extension : {".yml", ".xml", ".json"}) {
    for (int n : {4, 5, 8, 12, 14}) {
      // A row vector, a column vector (as calibrateCamera returns) and a plain list.
      for (int layout = 0; layout < 3; ++layout) {
        const std::string path = (dir / fmt::format("cam_{}_{}{}", n, layout, extension)).string();
        const cv::Mat D(1, n, CV_64F, const_cast<double*>(kDistortion));
        {
          cv::FileStorage storage(path, cv::FileStorage::WRITE);
          storage << "image_width" << 640 << "image_height" << 480 << "camera_matrix"
                  << cv::Mat(kK);
          if (layout == 0) storage << "distortion_coefficients" << D;
          if (layout == 1) storage << "distortion_coefficients" << cv::Mat(D.t());
          if (layout == 2) {
            storage << "distortion_coefficients"
                    << std::vector<double>(kDistortion, kDistortion + n);
          }
        }
        INFO(path);
        CHECK(IsOpenCvStorage(path));
        const Camera camera = ReadOpenCvCamera(path);
        CHECK(camera.model == Camera::Model::kPinhole);
        CHECK(camera.width == 640);
        CHECK(camera.height == 480);
        CHECK(camera.fx == Approx(kK(0, 0)).epsilon(1e-15));
        CHECK(camera.cy == Approx(kK(1, 2)).epsilon(1e-15));
        CHECK(MaxProjectionDifference(camera, cv::Mat(kK), D) < 1e-9);
      }
    }
  }
}

TEST_CASE("OpenCV camera files: the calibration tutorial's output, YAML and XML", "[vision]") {
  for (const char* file :
       {"tests/data/cameras/opencv_calibration.yml", "tests/data/cameras/opencv_calibration.xml"}) {
    const std::string path = testing::SourcePath(file);
    INFO(path);
    REQUIRE(IsOpenCvStorage(path));
    const Camera camera = ReadOpenCvCamera(path);
    CHECK(camera.fx == 812.4719238281250);
    CHECK(camera.fy == 810.9337158203125);
    CHECK(camera.cx == 321.87614440917969);
    CHECK(camera.cy == 238.41217041015625);
    CHECK(camera.distortion[0] == Approx(-0.089153602719306946).epsilon(1e-15));
    CHECK(camera.distortion[4] == Approx(-0.52087259292602539).epsilon(1e-15));
    CHECK(camera.distortion[5] == 0);
  }
}

TEST_CASE("ROS camera_info: read by the dsl, projects as cv::projectPoints", "[vision]") {
  const std::string path = testing::SourcePath("tests/data/cameras/ros_camera_info.yaml");
  CHECK_FALSE(IsOpenCvStorage(path));
  const Camera camera = ReadCameraFile(path);
  CHECK(camera.width == 640);
  CHECK(camera.height == 480);
  // The file's K and D (its rectification and projection matrices are not used).
  const cv::Matx33d K(612.48193, 0, 318.84302, 0, 611.96264, 247.01239, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(1, 5) << 0.095863, -0.208715, 0.001423, -0.000875, 0);
  CHECK(MaxProjectionDifference(camera, cv::Mat(K), D) < 1e-9);
}

TEST_CASE("OpenCV camera files: what is not one", "[vision]") {
  const TempDir temp("sniff");
  const fs::path& dir = temp.path;
  const std::vector<std::pair<std::string, bool>> files = {
      {"%YAML:1.0\n---\ncamera_matrix: 1\n", true},
      {"\xEF\xBB\xBF\n  %YAML:1.0\n", true},
      {"<?xml version=\"1.0\"?>\n<!-- calibration -->\n<opencv_storage>\n</opencv_storage>\n",
       true},
      {"{\n  \"camera_matrix\": {\"type_id\": \"opencv-matrix\", \"rows\": 3}}\n", true},
      {"%YAML 1.2\n---\nfx: 800\n", false},
      {"{\"fx\": 800, \"fy\": 800}\n", false},
      {"<robot name=\"r\"/>\n", false},
      {"image_width: 640\ncamera_matrix: {rows: 3, cols: 3, data: []}\n", false},
      {"", false}};
  int i = 0;
  for (const auto& [text, expected] : files) {
    const fs::path path = dir / fmt::format("f{}", i++);
    std::ofstream(path, std::ios::binary) << text;
    INFO(text);
    CHECK(IsOpenCvStorage(path.string()) == expected);
  }
  CHECK_FALSE(IsOpenCvStorage((dir / "missing.yml").string()));
  CHECK_FALSE(IsOpenCvStorage(dir.string()));
}

// A calibration file with one node replaced (or, for an empty value, left out).
std::string OpenCvYaml(const std::string& node, const std::string& value) {
  const std::vector<std::pair<std::string, std::string>> nodes = {
      {"image_width", "640"},
      {"image_height", "480"},
      {"camera_matrix",
       "!!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 800., 0., 320., 0., "
       "800., 240., 0., 0., 1. ]"},
      {"distortion_coefficients",
       "!!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ -0.1, 0.01, 0., 0., 0. ]"}};
  std::string text = "%YAML:1.0\n---\n";
  bool replaced = false;
  for (const auto& [name, v] : nodes) {
    const bool here = name == node;
    replaced |= here;
    if (here && value.empty()) continue;
    text += name + ": " + (here ? value : v) + "\n";
  }
  if (!replaced) text += node + ": " + value + "\n";
  return text;
}

std::string Matrix(int rows, int cols, const std::string& data) {
  return fmt::format("!!opencv-matrix\n   rows: {}\n   cols: {}\n   dt: d\n   data: [ {} ]", rows,
                     cols, data);
}

TEST_CASE("OpenCV camera files: every inconsistent file is refused by node and reason",
          "[vision]") {
  struct Case {
    std::string text;
    const char* node;
    const char* message;  // the start of the message
  };
  const std::string K = "camera_matrix", D = "distortion_coefficients";
  const std::vector<Case> cases = {
      {OpenCvYaml(K, ""), "camera_matrix",
       "missing (the file's nodes: image_width, image_height, distortion_coefficients)"},
      {OpenCvYaml(D, ""), "distortion_coefficients", "missing"},
      {OpenCvYaml("image_width", ""), "image_width", "missing"},
      {OpenCvYaml(K, "[ 800., 0., 320., 0., 800., 240., 0., 0., 1. ]"), "camera_matrix",
       "must be an OpenCV matrix"},
      {OpenCvYaml(K, "{ rows: 3, cols: 3 }"), "camera_matrix",
       "not an OpenCV matrix: it has no 'data'"},
      {OpenCvYaml(K, Matrix(3, 4, "800, 0, 320, 0, 0, 800, 240, 0, 0, 0, 1, 0")), "camera_matrix",
       "must be 3x3, got 3x4"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 320, 0, 800, 240, 0, 0")), "camera_matrix",
       "rows x cols = 3 x 3 = 9 but data has 8 values"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, abc, 0, 800, 240, 0, 0, 1")), "camera_matrix",
       "data[2] is not a number"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0.5, 320, 0, 800, 240, 0, 0, 1")), "camera_matrix",
       "the skew K[0][1] must be 0, got 0.5: cfuse's camera has no skew term"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 320, 3, 800, 240, 0, 0, 1")), "camera_matrix",
       "K[1][0] must be 0, got 3: a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1]"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 320, 0, 800, 240, 0.1, 0, 1")), "camera_matrix",
       "K[2][0] must be 0, got 0.1"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 320, 0, 800, 240, 0, 0, 2")), "camera_matrix",
       "K[2][2] must be 1, got 2"},
      {OpenCvYaml(K, Matrix(3, 3, "-800, 0, 320, 0, 800, 240, 0, 0, 1")), "camera_matrix",
       "fx = K[0][0] must be positive, got -800"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 320, 0, 0, 240, 0, 0, 1")), "camera_matrix",
       "fy = K[1][1] must be positive, got 0"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 320, 0, .Nan, 240, 0, 0, 1")), "camera_matrix",
       "K[1][1] must be finite, got nan"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 5000, 0, 800, 240, 0, 0, 1")), "camera_matrix",
       "the principal point cx = 5000 is outside [-640, 1280]"},
      {OpenCvYaml(K, Matrix(3, 3, "800, 0, 320, 0, 800, -600, 0, 0, 1")), "camera_matrix",
       "the principal point cy = -600 is outside [-480, 960]"},
      {OpenCvYaml(D, Matrix(1, 5, "-0.1, .Inf, 0, 0, 0")), "distortion_coefficients",
       "coefficient 2 (k2) must be finite, got inf"},
      {OpenCvYaml(D, Matrix(1, 6, "0, 0, 0, 0, 0, 0")), "distortion_coefficients",
       "has 6 coefficients; OpenCV's model takes 4, 5, 8, 12 or 14"},
      {OpenCvYaml(D, Matrix(1, 0, "")), "distortion_coefficients", "is empty"},
      {OpenCvYaml(D, Matrix(2, 4, "0, 0, 0, 0, 0, 0, 0, 0")), "distortion_coefficients",
       "must be 1xN or Nx1, got 2x4"},
      {OpenCvYaml(D, Matrix(14, 1, "-0.1, 0.01, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.01, 0")),
       "distortion_coefficients",
       "has the tilted-sensor coefficients tau_x = 0.01, tau_y = 0 (13th and 14th): cfuse's "
       "camera has no tilt, they must be 0"},
      {OpenCvYaml("image_width", "640.5"), "image_width",
       "must be a positive whole number of pixels, got 640.5"},
      {OpenCvYaml("image_height", "0"), "image_height",
       "must be a positive whole number of pixels, got 0"},
      {OpenCvYaml("image_height", "tall"), "image_height", "the value is not a number"},
      {OpenCvYaml("fisheye_model", "1"), "fisheye_model",
       "is 1: the coefficients are of OpenCV's fisheye (Kannala-Brandt) model"},
      // The same checks on XML.
      {"<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>\n"
       "<image_height>480</image_height>\n<camera_matrix type_id=\"opencv-matrix\">\n"
       "<rows>3</rows><cols>3</cols><dt>d</dt>\n<data>800 2 320 0 800 240 0 0 1</data>"
       "</camera_matrix>\n<distortion_coefficients type_id=\"opencv-matrix\">\n"
       "<rows>1</rows><cols>4</cols><dt>d</dt><data>0 0 0 0</data>"
       "</distortion_coefficients>\n</opencv_storage>\n",
       "camera_matrix", "the skew K[0][1] must be 0, got 2"},
  };
  const TempDir temp("refused");
  const fs::path& dir = temp.path;
  int i = 0;
  for (const Case& c : cases) {
    const std::string path = (dir / fmt::format("cam{}.yml", i++)).string();
    std::ofstream(path, std::ios::binary) << c.text;
    INFO(c.text);
    REQUIRE(IsOpenCvStorage(path));
    try {
      ReadOpenCvCamera(path);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().file == path);
      CHECK(e.where().line == 0);
      CHECK(e.where().element == c.node);
      CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
    }
  }
}

using namespace std::string_view_literals;

TEST_CASE("OpenCV camera files: syntax errors carry OpenCV's line; missing files", "[vision]") {
  const TempDir temp("syntax");
  const fs::path& dir = temp.path;
  struct Case {
    const char* name;
    std::string_view text;  // may hold a NUL
    int line;
    const char* message;
  };
  const Case cases[] = {
      {"bad.yml",
       "%YAML:1.0\n---\nimage_width: 640\ncamera_matrix: !!opencv-matrix\n   rows: 3\n  cols: "
       "3\n",
       6, "syntax error (cv::FileStorage): Incorrect indentation"},
      // Well-formed XML (a '>' may stand in text) that OpenCV's parser refuses.
      {"bad.xml",
       "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>\n"
       "<note>a</note>\n<note2>x > y</note2>\n</opencv_storage>\n",
       5, "syntax error (cv::FileStorage): Literal ' or > are not allowed"},
      // cv::FileStorage crashes on a NUL byte (found by fuzz/camera_fuzz.cpp): refused first.
      {"nul.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>\0</image_width>\n"sv, 0,
       "is a binary file, not a camera file (NUL byte at offset 52)"},
      // OpenCV's YAML parser throws std::length_error here (found by fuzz/camera_fuzz.cpp).
      {"colon.yml",
       "%YAML:1.0\n---\nm: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   :data: [ 8.1 ]\n",
       0, "cv::FileStorage cannot parse it (basic_string::_M_create)"}};
  for (const Case& c : cases) {
    const std::string path = (dir / c.name).string();
    std::ofstream(path, std::ios::binary).write(c.text.data(), std::streamsize(c.text.size()));
    INFO(c.text);
    try {
      ReadOpenCvCamera(path);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().file == path);
      CHECK(e.where().line == c.line);
      CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
    }
  }
  const std::string missing = (dir / "missing.yml").string();
  CHECK_THROWS_WITH(ReadOpenCvCamera(missing), missing + ": error: cannot open: no such file");
  CHECK_THROWS_WITH(ReadOpenCvCamera(dir.string()),
                    dir.string() + ": error: is a directory, not a camera file");
}

// The screen passes what OpenCV writes: strings holding quotes, brackets, '#', ':', '&' and '<'
// in each of the three formats, beside the camera.
TEST_CASE("OpenCV camera files: the screen passes every string OpenCV writes", "[vision]") {
  const TempDir temp("screen_passes");
  // (cv::FileStorage's writer takes a string starting with '[' or '{' to open a collection.)
  const std::string tricky[] = {"it's \"quoted\"", "a [b, c] {d: e}", "# not a comment",
                                "key: value",      "a & b < c > d",   "o'clock",
                                "x ]] > y",        "tab\there"};
  for (const char* extension : {".yml", ".xml", ".json"}) {
    const std::string path = (temp.path / fmt::format("tricky{}", extension)).string();
    {
      cv::FileStorage storage(path, cv::FileStorage::WRITE);
      storage << "image_width" << 640 << "image_height" << 480;
      for (size_t i = 0; i < std::size(tricky); ++i)
        storage << fmt::format("note{}", i) << tricky[i];
      storage << "notes" << std::vector<std::string>(std::begin(tricky), std::end(tricky));
      storage << "camera_matrix" << cv::Mat(kK) << "distortion_coefficients"
              << cv::Mat(1, 5, CV_64F, const_cast<double*>(kDistortion));
    }
    INFO(path);
    const Camera camera = ReadOpenCvCamera(path);
    CHECK(camera.fx == kK(0, 0));
    const cv::FileStorage storage(path, cv::FileStorage::READ);
    CHECK(storage["note4"].string() == tricky[4]);
  }
  // A document marker with a comment after it is a marker alone.
  CHECK_THROWS_WITH(ReadOpenCvCameraFromString("%YAML:1.0\n--- # calibration\na: 1\n", "c.yml"),
                    "c.yml: camera_matrix: error: missing (the file's nodes: a)");
}

}  // namespace
}  // namespace cfuse
