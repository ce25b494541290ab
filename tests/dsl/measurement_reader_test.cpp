// Measurement files: JSON and YAML read alike; every malformed entry is refused with the file,
// the line and column, the entry and the problem.
#include "cfuse/dsl/measurement_reader.h"

#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "test_util.h"

namespace cfuse {
namespace {

TEST_CASE("measurements: JSON and YAML spellings read the same", "[dsl]") {
  const MeasurementSet json = ReadMeasurementsFromString(R"({
  "camera": {"fx": 800, "fy": 810, "cx": 320, "cy": 240, "width": 640, "height": 480,
             "dist": [0.1, -0.01, 0.001, 0.002, 0.0]},
  "points": [ {"xyz": [0.1, 0.2, 1.5], "sigma": 0.002, "label": "p3"},
              {"xyz": [0.3, 0.1, 1.4], "cov": [[4e-6, 0, 0], [0, 4e-6, 1e-7], [0, 1e-7, 9e-6]]},
              {"uv": [321.5, 200.25], "sigma": 1.0, "label": "box.c000"},
              {"uv": [100, 50], "cov": [[2, 0.5], [0.5, 1]], "label": null} ]})",
                                                         "m.json");
  const MeasurementSet yaml = ReadMeasurementsFromString(R"(
camera: {fx: 800, fy: 810, cx: 320, cy: 240, width: 640, height: 480, dist: [0.1, -0.01, 0.001, 0.002, 0.0]}
points:
  - {xyz: [0.1, 0.2, 1.5], sigma: 0.002, label: p3}
  - xyz: [0.3, 0.1, 1.4]
    cov: [[4e-6, 0, 0], [0, 4e-6, 1e-7], [0, 1e-7, 9e-6]]
  - {uv: [321.5, 200.25], sigma: 1.0, label: box.c000}
  - {uv: [100, 50], cov: [[2, 0.5], [0.5, 1]]}
)",
                                                         "m.yaml");
  for (const MeasurementSet* s : {&json, &yaml}) {
    REQUIRE(s->camera);
    CHECK(s->camera->fy == 810);
    CHECK(s->camera->distortion[3] == 0.002);
    REQUIRE(s->points.size() == 4);
    CHECK(s->points[0].is_3d);
    CHECK(s->points[0].cov3(1, 1) == Approx(4e-6));
    CHECK(s->points[0].label == "p3");
    CHECK(s->points[1].label.empty());
    CHECK(s->points[1].cov3(2, 1) == 1e-7);
    CHECK(!s->points[2].is_3d);
    CHECK(s->points[2].uv.y() == 200.25);
    CHECK(s->points[3].cov2(0, 1) == 0.5);
    CHECK(s->points[3].label.empty());
  }
  CHECK(yaml.points[1].where.line == 5);
  CHECK(yaml.points[1].where.element == "points[1]");
}

TEST_CASE("measurements: every malformed file is refused where and how it should be", "[dsl]") {
  const testing::BadCase cases[] = {
      {"{}", 1, 1, "the measurements need 'points'"},
      {"points: [{xyz: [1, 2], sigma: 0.1}]", 1, 16,
       "points[0] xyz must be a list of 3 numbers, got 2"},
      {"points: [{xyz: [1, 2, x], sigma: 0.1}]", 1, 23, "points[0] xyz must be a number, got 'x'"},
      {"points: [{xyz: [1, 2, .nan], sigma: 0.1}]", 1, 23,
       "points[0] xyz must be finite, got '.nan'"},
      {"points: [{xyz: [1, 2, .inf], sigma: 0.1}]", 1, 23,
       "points[0] xyz must be finite, got '.inf'"},
      {"points: [{xyz: [1, 2, 3]}]", 1, 10, "points[0] needs either 'sigma' or 'cov'"},
      {"points: [{xyz: [1, 2, 3], sigma: 0.1, cov: [[1,0,0],[0,1,0],[0,0,1]]}]", 1, 10,
       "points[0] needs either 'sigma' or 'cov', not both"},
      {"points: [{xyz: [1, 2, 3], sigma: -0.1}]", 1, 34,
       "points[0] sigma must be positive, got -0.1"},
      {"points: [{xyz: [1, 2, 3], sigma: 1e200}]", 1, 34,
       "points[0] sigma must have a finite, nonzero square, got 1e+200"},
      {"points: [{xyz: [1, 2, 3], sigma: 1e-200}]", 1, 34,
       "points[0] sigma must have a finite, nonzero square, got 1e-200"},
      {"points: [{xyz: [1, 2, 3], cov: [[1,0,0],[0,1,0],[0,0,-1]]}]", 1, 32,
       "points[0] cov is not positive definite"},
      {"points: [{xyz: [1, 2, 3], cov: [[1,2,0],[0,1,0],[0,0,1]]}]", 1, 32,
       "points[0] cov is not symmetric"},
      {"points: [{xyz: [1, 2, 3], cov: [[1,0],[0,1]]}]", 1, 32,
       "points[0] cov must be a 3x3 matrix"},
      {"points: [{uv: [1, 2], sigma: 1}]", 1, 10,
       "points[0] is an image point but the file has no 'camera'"},
      {"points: [{xyz: [1, 2, 3], uv: [1, 2], sigma: 1}]", 1, 10,
       "points[0] needs either 'xyz' (a 3D point) or 'uv' (an image point), not both"},
      {"points: [{xyz: [1, 2, 3], sigma: 1, lable: p}]", 1, 37,
       "unknown key 'lable' in points[0] (did you mean 'label'?)"},
      {"points: [{xyz: [1, 2, 3], sigma: 1, label: [p]}]", 1, 44,
       "points[0] label must be a single value"},
      {"camera: {fx: 800, fy: 800, cx: 1, cy: 1, width: 640}\npoints: []", 1, 9,
       "the pinhole camera needs 'height'"},
      {"camera: {fx: -800, fy: 800, cx: 1, cy: 1, width: 640, height: 480}\npoints: []", 1, 14,
       "camera fx and fy must be positive"},
      {"camera: {fx: 800, fy: 0, cx: 1, cy: 1, width: 640, height: 480}\npoints: []", 1, 23,
       "camera fx and fy must be positive"},
      {"camera: {fx: 800, fy: 800, cx: 1, cy: 1, width: 640.5, height: 480}\npoints: []", 1, 49,
       "camera width must be a positive whole number of pixels"},
      {"camera: {fx: 800, fy: 800, cx: 1, cy: 1, width: 640, height: 480, dist: [1, 2, "
       "3]}\npoints: []",
       1, 73, "camera dist has 3 coefficients"},
      {"camera: {model: fisheye}\npoints: []", 1, 17, "unknown camera model 'fisheye'"},
      {"points: {a: 1}", 1, 9, "points must be a list"},
      {"- 1\n- 2", 1, 1, "a measurement file is a mapping with 'points'"},
      {"points: [{xyz: [1, 2, 3], sigma: 1}]\nextra: 1", 2, 1,
       "unknown key 'extra' in the measurements"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* file) { return ReadMeasurementsFromString(text, file); });
}

TEST_CASE("measurements: malformed JSON gets the YAML reader's message", "[dsl]") {
  // The fast path gives up on each; the message is the one a YAML spelling gets.
  const testing::BadCase cases[] = {
      {R"({"points": [{"xyz": [1, 2], "sigma": 0.1}]})", 1, 21,
       "points[0] xyz must be a list of 3 numbers, got 2"},
      {R"({"points": [{"xyz": [1, 2, 3]}]})", 1, 13, "points[0] needs either 'sigma' or 'cov'"},
      {R"({"points": [{"xyz": [1, 2, 3], "sigma": -0.1}]})", 1, 41,
       "points[0] sigma must be positive, got -0.1"},
      // Found by the measurements fuzz target: a sigma whose square overflows made a
      // covariance of inf on the diagonal and NaN off it.
      {R"({"points": [{"xyz": [1, 2, 3], "sigma": 1.01e308}]})", 1, 41,
       "points[0] sigma must have a finite, nonzero square, got 1.01e+308"},
      {R"({"points": [{"xyz": [1, 2, 3], "cov": [[1,2,0],[0,1,0],[0,0,1]]}]})", 1, 39,
       "points[0] cov is not symmetric"},
      {R"({"points": [{"xyz": [1, 2, 3], "sigma": 1, "label": ""}]})", 1, 53,
       "points[0] label is empty"},
      {R"({"points": [{"uv": [1, 2], "sigma": 1}]})", 1, 13,
       "points[0] is an image point but the file has no 'camera'"},
      {R"({"points": [{"xyz": [1, 2, 3], "sigma": 1, "lable": "p"}]})", 1, 44,
       "unknown key 'lable' in points[0]"},
      {R"({"points": [{"xyz": [1, 2, 3], "sigma": 1, "sigma": 2}]})", 1, 44,
       "duplicate key 'sigma' in points[0]"},
      {R"({"points": [{"xyz": [1, 2, 1e999], "sigma": 1}]})", 1, 28,
       "points[0] xyz must be finite"},
      {R"({"points": [{"xyz": [1, 2, 3], "sigma": 1}], "points": []})", 1, 46,
       "duplicate key 'points' in the measurements"},
      {R"({"camera": {"fx": 800}, "points": []})", 1, 12, "the pinhole camera needs 'fy'"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* file) { return ReadMeasurementsFromString(text, file); });
}

TEST_CASE("measurements: a million points are read, one more is refused", "[dsl][heavy]") {
  std::string text = "{\"points\": [";
  text.reserve(27u * kMaxMeasuredPoints + 64);
  for (int i = 0; i < kMaxMeasuredPoints; ++i) text += "{\"xyz\":[0,0,1],\"sigma\":1},";
  text.pop_back();
  const MeasurementSet set = ReadMeasurementsFromString(text + "]}", "big.json");
  CHECK(set.points.size() == size_t(kMaxMeasuredPoints));
  CHECK(set.points.back().where.line == 1);
  CHECK(set.points.back().where.column == 12 + 26 * (kMaxMeasuredPoints - 1) + 1);
  try {
    ReadMeasurementsFromString(text + ",{}]}", "big.json");
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().ToString() == "big.json:1:12");
    CHECK(e.message() == "more than 1000000 points");
  }
}

TEST_CASE("measurements: missing, empty and binary files", "[dsl]") {
  CHECK_THROWS_WITH(ReadMeasurements("no/such/file.json"),
                    "no/such/file.json: error: cannot open: no such file");
  CHECK_THROWS_WITH(ReadMeasurementsFromString("", "e.json"),
                    "e.json: error: file is empty: a measurement file needs 'points'");
  CHECK_THROWS_WITH(
      ReadMeasurementsFromString(std::string("{\"points\": []}\0", 15), "b.json"),
      "b.json: error: is a binary file, not a YAML measurement (NUL byte at offset 14)");
}

// A ROS camera_info in flow style, one entry a line (line i+1 is kRosInfo[i]).
const char* const kRosInfo[] = {
    "image_width: 640",
    "image_height: 480",
    "camera_name: cam",
    "camera_matrix: {rows: 3, cols: 3, data: [800, 0, 320, 0, 800, 240, 0, 0, 1]}",
    "distortion_model: plumb_bob",
    "distortion_coefficients: {rows: 1, cols: 5, data: [-0.1, 0.01, 0.001, 0.002, 0]}",
    "rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}",
    "projection_matrix: {rows: 3, cols: 4, data: [800, 0, 320, 0, 0, 800, 240, 0, 0, 0, 1, 0]}"};

// kRosInfo with lines replaced ({line, text}, 1-based; an empty text drops the line).
std::string RosInfo(const std::vector<std::pair<int, std::string>>& replaced = {}) {
  std::string text;
  for (int i = 0; i < 8; ++i) {
    std::string line = kRosInfo[i];
    for (const auto& [n, replacement] : replaced) {
      if (n == i + 1) line = replacement;
    }
    if (!line.empty()) text += line + "\n";
  }
  return text;
}

TEST_CASE("camera files: a ROS camera_info", "[dsl]") {
  const Camera flow = ReadCameraFromString(RosInfo(), "info.yaml");
  CHECK(flow.fx == 800);
  CHECK(flow.cy == 240);
  CHECK(flow.width == 640);
  CHECK(flow.distortion[3] == 0.002);
  CHECK(flow.distortion[5] == 0);

  // camera_calibration's block layout; its rectification and projection matrices are not used.
  const Camera block =
      ReadCameraFile(testing::SourcePath("tests/data/cameras/ros_camera_info.yaml"));
  CHECK(block.model == Camera::Model::kPinhole);
  CHECK(block.fx == 612.48193);
  CHECK(block.fy == 611.96264);
  CHECK(block.cx == 318.84302);
  CHECK(block.cy == 247.01239);
  CHECK(block.width == 640);
  CHECK(block.height == 480);
  CHECK(block.distortion[0] == 0.095863);
  CHECK(block.distortion[4] == 0.0);

  // Without distortion_model (older files): plumb_bob. rational_polynomial: 8, or OpenCV's 12 or
  // 14 with no tilt.
  CHECK(ReadCameraFromString(RosInfo({{5, ""}}), "old.yaml").distortion[1] == 0.01);
  const Camera rational = ReadCameraFromString(
      RosInfo({{5, "distortion_model: rational_polynomial"},
               {6,
                "distortion_coefficients: {rows: 1, cols: 8, data: [-0.1, 0.01, 0, 0, 0, 0.2, "
                "0.03, 0.004]}"}}),
      "rational.yaml");
  CHECK(rational.distortion[7] == 0.004);
  const Camera fourteen = ReadCameraFromString(
      RosInfo({{5, "distortion_model: rational_polynomial"},
               {6,
                "distortion_coefficients: {rows: 1, cols: 14, data: [-0.1, 0.01, 0, 0, 0, 0, 0, "
                "0, 0.001, 0, 0, 0.002, 0, 0]}"}}),
      "fourteen.yaml");
  CHECK(fourteen.distortion[11] == 0.002);
}

TEST_CASE("camera files: every inconsistent ROS camera_info is refused where and why", "[dsl]") {
  struct Case {
    std::string text;
    int line, column;
    const char* message;  // the start of the message
  };
  const std::string rows33 = "camera_matrix: {rows: 3, cols: 3, data: [";
  const Case cases[] = {
      {RosInfo({{4, rows33 + "800, 0.5, 320, 0, 800, 240, 0, 0, 1]}"}}), 4, 47,
       "camera_matrix: the skew K[0][1] must be 0, got 0.5: cfuse's camera has no skew term"},
      {RosInfo({{4, rows33 + "800, 0, 320, 3, 800, 240, 0, 0, 1]}"}}), 4, 55,
       "camera_matrix: K[1][0] must be 0, got 3: a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1]"},
      {RosInfo({{4, rows33 + "800, 0, 320, 0, 800, 240, 0, 0, 2]}"}}), 4, 74,
       "camera_matrix: K[2][2] must be 1, got 2"},
      {RosInfo({{4, rows33 + "-800, 0, 320, 0, 800, 240, 0, 0, 1]}"}}), 4, 42,
       "camera_matrix: fx = K[0][0] must be positive, got -800"},
      {RosInfo({{4, rows33 + "800, 0, 320, 0, 0, 240, 0, 0, 1]}"}}), 4, 58,
       "camera_matrix: fy = K[1][1] must be positive, got 0"},
      {RosInfo({{4, rows33 + "800, 0, 320, 0, .nan, 240, 0, 0, 1]}"}}), 4, 58,
       "camera_matrix data must be finite, got '.nan'"},
      {RosInfo({{4, rows33 + "800, 0, 5000, 0, 800, 240, 0, 0, 1]}"}}), 4, 50,
       "camera_matrix: the principal point cx = 5000 is outside [-640, 1280]"},
      {RosInfo({{4, rows33 + "800, 0, 320, 0, 800, 240, 0, 0]}"}}), 4, 41,
       "camera_matrix has rows: 3, cols: 3 but 8 values in data"},
      {RosInfo({{4,
                 "camera_matrix: {rows: 3, cols: 4, data: [800, 0, 320, 0, 0, 800, 240, 0, 0, "
                 "0, 1, 0]}"}}),
       4, 16, "camera_matrix must be 3x3, got rows: 3, cols: 4"},
      {RosInfo({{4, "camera_matrix: {rows: 3, cols: 3}"}}), 4, 16,
       "camera_matrix needs 'data' (a matrix is rows, cols and data)"},
      {RosInfo({{4,
                 "camera_matrix: !!opencv-matrix {rows: 3, cols: 3, dt: d, data: [800, 0, 320, "
                 "0, 800, 240, 0, 0, 1]}"}}),
       4, 16,
       "camera_matrix is an OpenCV matrix (!!opencv-matrix), but the file does not start with "
       "OpenCV's '%YAML:1.0'"},
      {RosInfo({{4, ""}}), 1, 1, "a ROS camera_info file needs 'camera_matrix'"},
      {RosInfo({{2, ""}}), 1, 1, "a ROS camera_info file needs 'image_height'"},
      {RosInfo({{1, "image_width: 640.5"}}), 1, 14,
       "image_width must be a positive whole number of pixels"},
      {RosInfo({{2, "image_height: -480"}}), 2, 15,
       "image_height must be a positive whole number of pixels"},
      {RosInfo({{6,
                 "distortion_coefficients: {rows: 1, cols: 4, data: [-0.1, 0.01, 0.001, "
                 "0.002]}"}}),
       6, 51,
       "distortion_coefficients has 4 coefficients but distortion_model plumb_bob takes 5 (k1 k2 "
       "p1 p2 k3)"},
      {RosInfo({{5, "distortion_model: rational_polynomial"}}), 6, 51,
       "distortion_coefficients has 5 coefficients but distortion_model rational_polynomial "
       "takes 8"},
      {RosInfo({{5, "distortion_model: rational_polynomial"},
                {6,
                 "distortion_coefficients: {rows: 1, cols: 14, data: [-0.1, 0.01, 0, 0, 0, 0, "
                 "0, 0, 0, 0, 0, 0, 0.01, 0]}"}}),
       6, 95,
       "distortion_coefficients has the tilted-sensor coefficients tau_x = 0.01, tau_y = 0 (13th "
       "and 14th): cfuse's camera has no tilt, they must be 0"},
      {RosInfo({{6,
                 "distortion_coefficients: {rows: 2, cols: 3, data: [-0.1, 0.01, 0.001, 0.002, "
                 "0, 0]}"}}),
       6, 26, "distortion_coefficients must be 1xN, got rows: 2, cols: 3"},
      {RosInfo({{5, "distortion_model: equidistant"}}), 5, 19,
       "distortion_model 'equidistant' is the fisheye (Kannala-Brandt) model; cfuse's camera has "
       "OpenCV's pinhole distortion only (plumb_bob or rational_polynomial)"},
      {RosInfo({{5, "distortion_model: fancy"}}), 5, 19,
       "unknown distortion_model 'fancy': cfuse reads plumb_bob and rational_polynomial"},
      {RosInfo({{5, "distortion_modle: plumb_bob"}}), 5, 1,
       "unknown key 'distortion_modle' in the camera_info (did you mean 'distortion_model'?)"},
      {RosInfo({{3, "fx: 800"}}), 3, 1, "unknown key 'fx' in the camera_info"},
      {RosInfo({{8,
                 "projection_matrix: {rows: 3, cols: 3, data: [800, 0, 320, 0, 800, 240, 0, 0, "
                 "1]}"}}),
       8, 20, "projection_matrix must be 3x4, got rows: 3, cols: 3"},
      {RosInfo({{7, "rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0]}"}}),
       7, 48, "rectification_matrix has rows: 3, cols: 3 but 8 values in data"},
      // cfuse's own camera object: the same checks where they apply.
      {"{fx: 800, fy: 800, cx: 2000, cy: 240, width: 640, height: 480}", 1, 24,
       "the principal point cx = 2000 is outside [-640, 1280], a whole image beyond the 640 x 480 "
       "image: is the camera matrix for another image size?"},
      {"{fx: 800, fy: 800, cx: 320, cy: -500, width: 640, height: 480}", 1, 33,
       "the principal point cy = -500 is outside [-480, 960]"},
      {"{fx: 800, fy: 800, cx: 320, cy: 240, width: 640, height: 480, dist: [0, 0, 0, 0, 0, 0, 0, "
       "0, 0, 0, 0, 0, 0, 0.5]}",
       1, 109, "camera dist has the tilted-sensor coefficients tau_x = 0, tau_y = 0.5"},
  };
  for (const Case& c : cases) {
    INFO(c.text);
    try {
      ReadCameraFromString(c.text, "bad.yaml");
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().file == "bad.yaml");
      CHECK(e.where().line == c.line);
      CHECK(e.where().column == c.column);
      CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
    }
  }
  // OpenCV's 14 coefficients without tilt are accepted in cfuse's own format too.
  CHECK(ReadCameraFromString("{fx: 800, fy: 800, cx: 320, cy: 240, width: 640, height: 480, dist: "
                             "[0.1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.2, 0, 0]}",
                             "c.yaml")
            .distortion[11] == 0.2);
}

}  // namespace
}  // namespace cfuse
