// The renderer's truth against the model's visible edges (cfuse/geometry/model_edges.h).
#include "cfuse/vision/render.h"

#include <algorithm>
#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/geometry/model_edges.h"
#include "test_util.h"

namespace cfuse {
namespace {

TEST_CASE("render: the truth lies on the visible edges, hidden parts removed", "[vision]") {
  // The hinged box with its lid open: the truth's segments lie on the projected visible edges
  // and add up to no more than them (hidden and contrast-less stretches are left out).
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera camera = testing::Pinhole();
  camera.fx = camera.fy = 1000;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(2.3, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();
  Values v = g.nominal;
  for (Rigid3d& pose : v.poses) {
    pose =
        Rigid3d(R, Eigen::Vector3d(-0.05, 0.1, 1.8) - R * Eigen::Vector3d(0.15, 0.12, 0.1)) * pose;
  }
  RenderOptions ro;
  ro.clutter_lines = ro.clutter_blobs = 0;
  const Rendering r = Render(g, v, camera, ro);
  const std::vector<ModelEdge> edges = ModelEdges(g);
  const std::vector<ProjectedEdge> visible = VisibleEdges(g, edges, v, camera);
  REQUIRE(!r.truth.empty());
  double truth_length = 0, visible_length = 0;
  for (const TruthSegment& t : r.truth) {
    truth_length += (t.b - t.a).norm();
    const auto on = std::find_if(visible.begin(), visible.end(),
                                 [&](const ProjectedEdge& e) { return e.edge == t.edge; });
    REQUIRE(on != visible.end());
    const Eigen::Vector2d d = (on->b - on->a).normalized();
    for (const Eigen::Vector2d& p : {t.a, t.b}) {
      CHECK(std::abs(d.x() * (p - on->a).y() - d.y() * (p - on->a).x()) < 1e-6);
    }
  }
  for (const ProjectedEdge& e : visible) visible_length += (e.b - e.a).norm();
  CHECK(truth_length <= visible_length + 1e-6);
  CHECK(r.pixels.size() == static_cast<size_t>(640 * 480));
  // A camera without a size, or with distortion, is refused.
  Camera sizeless = camera;
  sizeless.width = 0;
  CHECK_THROWS_AS(Render(g, v, sizeless, ro), InputError);
  Camera distorted = camera;
  distorted.distortion[0] = -0.1;
  CHECK_THROWS_AS(Render(g, v, distorted, ro), InputError);
}

}  // namespace
}  // namespace cfuse
