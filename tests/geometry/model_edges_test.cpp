// A model's visible edges: back faces culled, wires always shown, clipping to the image and to
// the space in front of the camera. (The renderer's truth lying on them: vision/render_test.cpp.)
#include "cfuse/geometry/model_edges.h"

#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "test_util.h"

namespace cfuse {
namespace {

// The hinged box's box alone: a 300 x 250 x 200 mm box with its 12 edges and 6 faces.
ConstraintGraph Box() {
  return LoadModelFromString(R"(
name: box
units: {length: mm}
components:
  box:
    points: {c000: [0, 0, 0], c100: [300, 0, 0], c110: [300, 250, 0], c010: [0, 250, 0],
             c001: [0, 0, 200], c101: [300, 0, 200], c111: [300, 250, 200], c011: [0, 250, 200]}
    edges: {wire: [c000, c111]}
    faces:
      bottom: [c000, c010, c110, c100]
      top: [c001, c101, c111, c011]
      front: [c000, c100, c101, c001]
      back: [c110, c010, c011, c111]
      left: [c010, c000, c001, c011]
      right: [c100, c110, c111, c101]
)",
                                  "box.yaml", ".");
}

Values At(const ConstraintGraph& g, const Rigid3d& camera_from_box) {
  Values v = g.nominal;
  v.poses[0] = camera_from_box;
  return v;
}

TEST_CASE("model edges: faces' sides and wires, each once", "[geometry]") {
  const ConstraintGraph g = Box();
  const std::vector<ModelEdge> edges = ModelEdges(g);
  // The wire, then the 12 sides of the 6 faces (each shared by two faces).
  REQUIRE(edges.size() == 13);
  CHECK(edges[0].name == "wire");
  CHECK(edges[0].faces.empty());
  for (size_t i = 1; i < edges.size(); ++i) CHECK(edges[i].faces.size() == 2);
}

TEST_CASE("model edges: a view onto a corner shows three faces and nine edges", "[geometry]") {
  const ConstraintGraph g = Box();
  const Camera camera = testing::Pinhole();
  // The box's centre 1.5 m in front of the camera, turned so that the corner c000 faces it:
  // the bottom, front and left faces (those through c000) face the camera.
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(-0.6, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()))
                                .toRotationMatrix();
  const Eigen::Vector3d centre(0.15, 0.125, 0.1);
  const Values v = At(g, Rigid3d(R, Eigen::Vector3d(0, 0, 1.5) - R * centre));
  int front = 0;
  for (int f = 0; f < 6; ++f) front += FrontFacing(g, 0, f, v, camera) ? 1 : 0;
  CHECK(front == 3);
  const std::vector<ModelEdge> edges = ModelEdges(g);
  const std::vector<ProjectedEdge> visible = VisibleEdges(g, edges, v, camera);
  // The three faces' nine sides, and the wire.
  CHECK(visible.size() == 10);
  for (const ProjectedEdge& e : visible) {
    // Inside the image, and the projection of the 3D ends.
    for (const Eigen::Vector2d& p : {e.a, e.b}) {
      CHECK(p.x() >= -0.5);
      CHECK(p.x() <= 639.5);
    }
    CHECK((camera.Project<double>(e.A) - e.a).norm() < 1e-9);
    CHECK((camera.Project<double>(e.B) - e.b).norm() < 1e-9);
  }
}

TEST_CASE("model edges: clipped to the image and to the space before the camera", "[geometry]") {
  const ConstraintGraph g = Box();
  const Camera camera = testing::Pinhole();
  // Seen from 0.25 m, far larger than the image: every visible edge ends inside the image.
  const Values near =
      At(g, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.15, -0.12, 0.25)));
  for (const ProjectedEdge& e : VisibleEdges(g, ModelEdges(g), near, camera)) {
    for (const Eigen::Vector2d& p : {e.a, e.b}) {
      CHECK(p.x() >= -0.5 - 1e-9);
      CHECK(p.x() <= 639.5 + 1e-9);
      CHECK(p.y() >= -0.5 - 1e-9);
      CHECK(p.y() <= 479.5 + 1e-9);
    }
  }
  // Half of the box behind the camera: what is left starts 1 mm in front of it.
  const Values across =
      At(g, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.15, -0.12, -0.1)));
  for (const ProjectedEdge& e : VisibleEdges(g, ModelEdges(g), across, camera)) {
    CHECK(e.A.z() >= 1e-3 - 1e-12);
    CHECK(e.B.z() >= 1e-3 - 1e-12);
  }
  // Wholly behind it: nothing.
  const Values behind = At(g, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, -1)));
  CHECK(VisibleEdges(g, ModelEdges(g), behind, camera).empty());
}

TEST_CASE("model edges: the rectangle clip", "[geometry]") {
  const Eigen::Vector2d lo(0, 0), hi(10, 10);
  Eigen::Vector2d a(-5, 5), b(15, 5);
  REQUIRE(ClipToRectangle(lo, hi, &a, &b));
  CHECK((a - Eigen::Vector2d(0, 5)).norm() < 1e-12);
  CHECK((b - Eigen::Vector2d(10, 5)).norm() < 1e-12);
  a = {-5, -5};
  b = {-1, 20};
  CHECK_FALSE(ClipToRectangle(lo, hi, &a, &b));
  a = {2, 3};
  b = {4, 5};
  REQUIRE(ClipToRectangle(lo, hi, &a, &b));
  CHECK((a - Eigen::Vector2d(2, 3)).norm() < 1e-12);
}

}  // namespace
}  // namespace cfuse
