// Labels resolved to model points: every form a label takes, unknown and ambiguous labels
// refused at the measurement, and labelled points in other units than the model's refused at
// the file with the likely unit.
#include <catch2/catch.hpp>

#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/interp/solve.h"
#include "test_util.h"

namespace cfuse {
namespace {

// Two parts with a point of the same name, and a single point.
const char* const kTwins = R"(name: twins
units: {length: mm}
components:
  left:
    points: {corner: [0, 0, 0], tip: [100, 0, 0], top: [0, 100, 0]}
  right:
    points: {corner: [200, 0, 0], end: [300, 0, 0], up: [200, 100, 0]}
points: {hub: [100, 100, 0]}
)";

MeasuredPoint Labelled(const std::string& label, int line) {
  MeasuredPoint m;
  m.xyz = Eigen::Vector3d(0, 0, 1);
  m.cov3 = 1e-6 * Eigen::Matrix3d::Identity();
  m.label = label;
  m.where = SourceLocation("m.json", line, 5, "points[" + std::to_string(line - 2) + "]");
  return m;
}

// The box's corners of the hinged box at `scale` times their nominal places, labelled.
MeasurementSet BoxCorners(const ConstraintGraph& g, double scale, bool is_3d = true) {
  MeasurementSet set;
  set.source = "corners.json";
  const Component& box = g.components[g.FindComponent("box")];
  for (const FeaturePoint& p : box.points) {
    MeasuredPoint m;
    m.is_3d = is_3d;
    m.xyz = scale * p.position;
    m.cov3 = 1e-10 * Eigen::Matrix3d::Identity();  // 10 µm: every pair is judged
    m.uv = Eigen::Vector2d(p.position.x(), p.position.y());
    m.cov2 = Eigen::Matrix2d::Identity();
    m.label = "box." + p.name;
    set.points.push_back(m);
  }
  if (!is_3d) set.camera = testing::Pinhole();
  return set;
}

TEST_CASE("resolve labels: component.point, a unique point's name, a single point's name",
          "[interp]") {
  ConstraintGraph g = LoadModelFromString(kTwins, "twins.yaml", ".");
  MeasurementSet set;
  set.points = {Labelled("right.corner", 3), Labelled("", 4), Labelled("tip", 5),
                Labelled("hub", 6), Labelled("up", 7)};
  const std::vector<ResolvedLabel> labels = ResolveLabels(g, set);
  REQUIRE(labels.size() == 4);  // the unlabelled measurement is left out
  const int left = g.FindComponent("left"), right = g.FindComponent("right");
  auto is = [](const ResolvedLabel& r, int m, int c, int f) {
    return r.measurement == m && r.component == c && r.feature == f;
  };
  CHECK(is(labels[0], 0, right, 0));
  CHECK(is(labels[1], 2, left, 1));
  CHECK(is(labels[2], 3, g.FindComponent("hub"), -1));
  CHECK(is(labels[3], 4, right, 2));
  // A component whose own name holds a dot (a URDF link's may): the label is split at the dot
  // that names a model point.
  g.components[right].name = "right.v2";
  set.points = {Labelled("right.v2.end", 3)};
  CHECK(is(ResolveLabels(g, set).at(0), 0, right, 1));
}

TEST_CASE("resolve labels: unknown and ambiguous labels are refused at their measurement",
          "[interp]") {
  const ConstraintGraph g = LoadModelFromString(kTwins, "twins.yaml", ".");
  const struct {
    const char* label;
    const char* error;
  } cases[] = {
      {"corner",
       "m.json:3:5: points[1]: error: label 'corner' is ambiguous: write "
       "component.point"},
      {"left.end", "m.json:3:5: points[1]: error: unknown label 'left.end': no such model point"},
      {"hub.x", "m.json:3:5: points[1]: error: unknown label 'hub.x': no such model point"},
      {"lfet.tip",
       "m.json:3:5: points[1]: error: unknown label 'lfet.tip': no such model point "
       "(did you mean 'left.tip'?)"},
      {"left", "m.json:3:5: points[1]: error: unknown label 'left': no such model point"},
  };
  for (const auto& c : cases) {
    MeasurementSet set;
    set.points = {Labelled("tip", 2), Labelled(c.label, 3)};
    CHECK_THROWS_WITH(ResolveLabels(g, set), c.error);
  }
}

TEST_CASE("solve: unknown and ambiguous labels are errors at the measurement", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const MeasurementSet set = ReadMeasurementsFromString(
      "points:\n  - {xyz: [0, 0, 1], sigma: 0.01, label: box.c000}\n"
      "  - {xyz: [0, 0, 1], sigma: 0.01, label: box.c999}\n",
      "meas.yaml");
  try {
    Solve(g, set);
    FAIL("an unknown label was accepted");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) ==
          "meas.yaml:3:5: points[1]: error: unknown label 'box.c999': no such model point");
  }
  // A typo gets the closest label; interpret refuses it as well, though labels do not steer it.
  const MeasurementSet typo = ReadMeasurementsFromString(
      "points:\n  - {xyz: [0, 0, 1], sigma: 0.01, label: bx.c010}\n", "meas.yaml");
  const std::string expected =
      "meas.yaml:2:5: points[0]: error: unknown label 'bx.c010': no such model point (did you "
      "mean 'box.c010'?)";
  CHECK_THROWS_WITH(Solve(g, typo), expected);
  CHECK_THROWS_WITH(Interpret(g, typo), expected);
}

TEST_CASE("solve: measurements in millimetres are refused at the file, with the likely unit",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  MeasurementSet set = BoxCorners(g, 1);
  set.source = "mm.json";
  CHECK(Solve(g, set).accepted());
  for (MeasuredPoint& m : set.points) {
    m.xyz *= 1000;
    m.cov3 *= 1e6;
  }
  CHECK_THROWS_WITH(
      Solve(g, set),
      Catch::Matches("mm\\.json: error: the labelled points are about 1000 times "
                     "as far apart as the model points they name \\(median over [0-9]+ "
                     "pairs\\): millimetres\\? measurement files take metres"));
}

TEST_CASE("resolve labels: the scale of labelled points, measured against the model's",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  // The box's 8 corners make 28 pairs; the median ratio is the scale, to two digits.
  const std::string head = "corners.json: error: the labelled points are about ";
  const std::string tail = " as far apart as the model points they name (median over 28 pairs)";
  CHECK_THROWS_WITH(ResolveLabels(g, BoxCorners(g, 100)),
                    head + "100 times" + tail + ": centimetres? measurement files take metres");
  CHECK_THROWS_WITH(ResolveLabels(g, BoxCorners(g, 1 / 0.0254)),
                    head + "39 times" + tail + ": inches? measurement files take metres");
  CHECK_THROWS_WITH(ResolveLabels(g, BoxCorners(g, 300)), head + "300 times" + tail);
  CHECK_THROWS_WITH(ResolveLabels(g, BoxCorners(g, 0.01)), head + "0.01 times" + tail);
  // Within a factor of 20 either way: the data's business.
  CHECK(ResolveLabels(g, BoxCorners(g, 10)).size() == 8);
  CHECK(ResolveLabels(g, BoxCorners(g, 0.1)).size() == 8);
  // Too few pairs to judge, and image points, which have no scale, are not judged.
  MeasurementSet two = BoxCorners(g, 1000);
  two.points.resize(2);
  CHECK(ResolveLabels(g, two).size() == 2);
  CHECK(ResolveLabels(g, BoxCorners(g, 1000, false)).size() == 8);
}

}  // namespace
}  // namespace cfuse
