// The JSON fast path for measurement files (dsl/src/measurement_json.cpp): the sigma and
// covariance tests both readers share; what it reads, with the locations the YAML reader gives,
// and what it leaves to the YAML reader; its one refusal, a file of too many points; and the
// comparison of two readings.
#include "measurement_json.h"

#include <fmt/format.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cfuse/dsl/measurement_reader.h"
#include "test_util.h"

namespace cfuse {
namespace {

// The JSON fast path (dsl/src/measurement_json.h) must agree with the YAML reader on everything
// it accepts. A trailing YAML comment hides a file from the fast path (it is not JSON) without
// moving anything, so reading `text + "\n#"` is the YAML reader's answer.
MeasurementSet ReadByYaml(const std::string& text, const std::string& file) {
  return ReadMeasurementsFromString(text + "\n#", file);
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST_CASE("measurement json: the JSON fast path reads as the YAML reader does", "[dsl]") {
  std::vector<std::string> texts;
  for (const auto& entry :
       std::filesystem::directory_iterator(testing::SourcePath("fuzz/seeds/measurements"))) {
    if (entry.path().extension() == ".json") texts.push_back(Slurp(entry.path().string()));
  }
  texts.push_back(Slurp(testing::SourcePath("tests/data/lamp-measurements.json")));
  REQUIRE(texts.size() >= 5);
  // Pretty-printed, with tabs, in any key order, camera after the points, nulls.
  std::string many = "{\n\t\"points\": [\n";
  for (int i = 0; i < 2000; ++i) {
    many += fmt::format("{}  {{\"label\": {}, \"sigma\": {}, \"xyz\": [{}, -{}e-3, {}]}}",
                        i ? ",\n" : "", i % 3 ? fmt::format("\"p{}\"", i) : "null",
                        0.001 * (1 + i % 7), i, i, 1.5 + 1e-4 * i);
  }
  many +=
      ",\n{\"uv\": [1, 2], \"cov\": [[2, 0.5], [0.5, 1]]}],\n \"camera\": {\"fx\": 800, "
      "\"fy\": 800, \"cx\": 320, \"cy\": 240, \"width\": 640, \"height\": 480}}\n";
  texts.push_back(many);
  for (const std::string& text : texts) {
    const MeasurementSet fast = ReadMeasurementsFromString(text, "m.json");
    const MeasurementSet yaml = ReadByYaml(text, "m.json");
    CHECK(SameMeasurements(fast, yaml));
  }
  // The fast path takes these itself (the comparison above would pass if it gave up on all).
  const auto read_camera = [](std::string_view) { return testing::Pinhole(); };
  for (const std::string& text : texts)
    CHECK(ReadPlainJsonMeasurements(text, "m.json", read_camera));
}

// Found by the `measurements` fuzz target: JSON that YAML 1.2 cannot parse (a line break
// between a key and its colon makes an implicit key span lines) is read by the fast path.
TEST_CASE("measurement json: JSON beyond YAML's syntax is read all the same", "[dsl]") {
  const std::string text =
      "{\"points\"\n\n: [{\"xyz\": [1, 2, 3], \"sigma\": 0.5, \"label\": \"a\"}]}";
  const MeasurementSet set = ReadMeasurementsFromString(text, "m.json");
  REQUIRE(set.points.size() == 1);
  CHECK(set.points[0].label == "a");
  CHECK(set.points[0].where.ToString() == "m.json:3:4: points[0]");
  CHECK_THROWS_WITH(ReadByYaml(text, "m.json"), Catch::Contains("YAML syntax error"));
}

// Found by the `measurements` fuzz target: a covariance asymmetric within the tolerance (relative
// to its largest entry) was symmetrised in place, reading entries already overwritten.
TEST_CASE("measurement json: a nearly symmetric cov is made exactly symmetric, as YAML does",
          "[dsl]") {
  const std::string text =
      R"({"points": [{"xyz": [1, 2, 3], "cov": [[4e-6, 0, 0], [0, 4e-6, 0], [1, 0, 4e206]]}]})";
  const MeasurementSet fast = ReadMeasurementsFromString(text, "m.json");
  const MeasurementSet yaml = ReadByYaml(text, "m.json");
  REQUIRE(fast.points.size() == 1);
  const Eigen::Matrix3d& C = fast.points[0].cov3;
  CHECK(C == C.transpose());
  CHECK(C(0, 2) == 0.5);
  CHECK(SameMeasurements(fast, yaml));
}

// The fast path's own refusal: a valid point beyond the limit (an invalid one would hand the
// file to the YAML reader, which refuses it too, but some 20 times slower).
TEST_CASE("measurement json: the fast path refuses a million points and one", "[dsl][heavy]") {
  std::string text = "{\"points\": [";
  const std::string point = "{\"xyz\":[0,0,1],\"sigma\":1},";
  text.reserve(point.size() * (kMaxMeasuredPoints + 1) + 64);
  for (int i = 0; i <= kMaxMeasuredPoints; ++i) text += point;
  text.back() = ']';
  try {
    ReadPlainJsonMeasurements(text + "}", "big.json",
                              [](std::string_view) { return testing::Pinhole(); });
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().ToString() == "big.json:1:12");
    CHECK(e.message() == "more than 1000000 points");
  }
}

TEST_CASE("measurement json: sigmas and covariances both readers refuse", "[dsl]") {
  CHECK_FALSE(SigmaProblem(0.002));
  CHECK_FALSE(SigmaProblem(1e150));
  CHECK(SigmaProblem(0) == "must be positive, got 0");
  CHECK(SigmaProblem(-0.5) == "must be positive, got -0.5");
  CHECK(SigmaProblem(std::nan("")) == "must be positive, got nan");
  // Its square must be a normal number: not infinite, not zero, not subnormal.
  CHECK(SigmaProblem(1e200) == "must have a finite, nonzero square, got 1e+200");
  CHECK(SigmaProblem(1e-160) == "must have a finite, nonzero square, got 1e-160");

  CHECK_FALSE(CovarianceProblem(Eigen::Matrix3d::Identity()));
  Eigen::Matrix2d C;
  C << 4, 1, 1 + 3e-9, 1;  // asymmetric within 1e-9 of its largest entry
  CHECK_FALSE(CovarianceProblem(C));
  C(1, 0) = 1 + 5e-9;
  CHECK(CovarianceProblem(C) == "is not symmetric");
  C << 1, 2, 2, 1;  // eigenvalues 3 and -1
  CHECK(CovarianceProblem(C) == "is not positive definite");
  C << 1, 1, 1, 1;  // singular
  CHECK(CovarianceProblem(C) == "is not positive definite");
  CHECK(CovarianceProblem(Eigen::Matrix2d::Zero()) == "is not positive definite");
  C(0, 1) = std::numeric_limits<double>::infinity();
  CHECK(CovarianceProblem(C) == "has an entry that is not a finite number");
}

std::optional<MeasurementSet> Fast(const std::string& text) {
  return ReadPlainJsonMeasurements(text, "m.json",
                                   [](std::string_view) { return testing::Pinhole(); });
}

TEST_CASE("measurement json: points with their places; the camera's text to its reader", "[dsl]") {
  const std::string text =
      "{\"points\": [\n"
      "  {\"xyz\": [1, 2, 3], \"cov\": [[4, 1, 0], [1, 4, 0], [0, 0, 1]], \"label\": \"p\"},\n"
      "    {\"uv\": [320.5, 240], \"sigma\": 0.5, \"label\": null}],\n"
      " \"camera\": {\"fx\": 800, \"extra\": {\"nested\": [true, null, \"x\"]}}}";
  std::string camera_text;
  const std::optional<MeasurementSet> set =
      ReadPlainJsonMeasurements(text, "m.json", [&](std::string_view camera) {
        camera_text = camera;
        return testing::Pinhole();
      });
  REQUIRE(set);
  CHECK(camera_text == "{\"fx\": 800, \"extra\": {\"nested\": [true, null, \"x\"]}}");
  CHECK(set->source == "m.json");
  REQUIRE(set->camera);
  CHECK(set->camera->fx == 800);
  REQUIRE(set->points.size() == 2);
  const MeasuredPoint& p = set->points[0];
  CHECK(p.is_3d);
  CHECK(p.xyz == Eigen::Vector3d(1, 2, 3));
  CHECK(p.cov3(0, 1) == 1);
  CHECK(p.label == "p");
  CHECK(p.where.ToString() == "m.json:2:3: points[0]");
  const MeasuredPoint& q = set->points[1];
  CHECK_FALSE(q.is_3d);
  CHECK(q.uv == Eigen::Vector2d(320.5, 240));
  CHECK(q.cov2 == 0.25 * Eigen::Matrix2d::Identity());
  CHECK(q.label.empty());
  CHECK(q.where.ToString() == "m.json:3:5: points[1]");
}

TEST_CASE("measurement json: what it leaves to the YAML reader", "[dsl]") {
  const std::string point = "{\"xyz\": [1, 2, 3], \"sigma\": 1}";
  REQUIRE(Fast("{\"points\": [" + point + "]}"));
  const std::vector<std::string> texts = {
      "points: [" + point + "]",                  // YAML, not JSON
      "{\"points\": [" + point + "]} # comment",  // not JSON either
      "{\"points\": [{\"xyz\": [1, 2, 3], \"sigma\": 1, \"label\": \"caf\xC3\xA9\"}]}",
      "{\"points\": [{\"xyz\": [1, 2, 3], \"sigma\": 1, \"label\": \"\\u0041\"}]}",
      "{\"points\": [" + point + "]}\r\n",              // a carriage return
      "{\"camera\": {}}",                               // no points
      "{\"points\": [" + point + "], \"extra\": 1}",    // an unknown key
      "{\"points\": [" + point + "], \"points\": []}",  // a key twice
      "{\"points\": [{\"xyz\": [1, 2, 3], \"uv\": [1, 2], \"sigma\": 1}]}",
      "{\"points\": [{\"xyz\": [1, 2], \"sigma\": 1}]}",
      "{\"points\": [{\"xyz\": [1, 2, 3, 4], \"sigma\": 1}]}",
      "{\"points\": [{\"xyz\": [1, 2, 3], \"sigma\": 1, \"sigma\": 1}]}",
      "{\"points\": [{\"xyz\": [1, 2, 3], \"sigma\": -1}]}",
      "{\"points\": [{\"xyz\": [1, 2, 3], \"cov\": [[1, 0], [0, 1]]}]}",
      "{\"points\": [{\"xyz\": [1, 2, 3], \"sigma\": 1, \"label\": \"\"}]}",
      "{\"points\": [{\"xyz\": [1, 2, 3], \"sigma\": true}]}",
      "{\"points\": [{\"uv\": [1, 2], \"sigma\": 1}]}",  // no camera
      "{\"points\": [" + point + "]",                    // unclosed
  };
  for (const std::string& text : texts) {
    INFO(text);
    CHECK_FALSE(Fast(text));
  }
  // A camera its reader refuses: the YAML reader will say why.
  CHECK_FALSE(ReadPlainJsonMeasurements(
      "{\"camera\": {}, \"points\": []}", "m.json",
      [](std::string_view) -> Camera { throw InputError(SourceLocation("m.json"), "bad"); }));
}

TEST_CASE("measurement json: two readings compared field by field", "[dsl]") {
  const MeasurementSet a = *Fast(
      "{\"camera\": {}, \"points\": [{\"xyz\": [1, 2, 3], \"sigma\": 1, \"label\": \"p\"}, "
      "{\"uv\": [5, 6], \"sigma\": 2}]}");
  CHECK(SameMeasurements(a, a));
  std::vector<MeasurementSet> changed(10, a);
  changed[0].source = "n.json";
  changed[1].camera.reset();
  changed[2].camera->cy += 1;
  changed[3].points.pop_back();
  changed[4].points[0].is_3d = false;
  changed[5].points[0].xyz.z() = 3.5;
  changed[6].points[0].cov3(2, 2) = 2;
  changed[7].points[1].uv.x() = 5.5;
  changed[8].points[0].label = "q";
  changed[9].points[1].where.line += 1;
  for (size_t k = 0; k < changed.size(); ++k) {
    INFO("change " << k);
    CHECK_FALSE(SameMeasurements(a, changed[k]));
    CHECK_FALSE(SameMeasurements(changed[k], a));
  }
}

}  // namespace
}  // namespace cfuse
