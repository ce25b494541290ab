// Measurement files: JSON and YAML read alike; every malformed entry is refused with the file,
// the line and column, the entry and the problem.
#include "dsl/measurement_reader.h"

#include <catch2/catch.hpp>

#include "test_util.h"

namespace cfuse::dsl {
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
      {"camera: {fx: -800, fy: 800, cx: 1, cy: 1, width: 640, height: 480}\npoints: []", 1, 9,
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

TEST_CASE("measurements: missing, empty and binary files", "[dsl]") {
  CHECK_THROWS_WITH(ReadMeasurements("no/such/file.json"),
                    "no/such/file.json: error: cannot open: no such file");
  CHECK_THROWS_WITH(ReadMeasurementsFromString("", "e.json"),
                    "e.json: error: file is empty: a measurement file needs 'points'");
  CHECK_THROWS_WITH(
      ReadMeasurementsFromString(std::string("{\"points\": []}\0", 15), "b.json"),
      "b.json: error: is a binary file, not a YAML measurement (NUL byte at offset 14)");
}

}  // namespace
}  // namespace cfuse::dsl
