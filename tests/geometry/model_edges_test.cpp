// A model's visible edges: back faces culled, wires always shown, clipping to the image and to
// the space in front of the camera. (The renderer's truth lying on them: vision/render_test.cpp.)
#include "cfuse/geometry/model_edges.h"

#include <catch2/catch.hpp>
#include <random>
#include <string>

#include "cfuse/dsl/model_loader.h"
#include "test_util.h"

namespace cfuse {
namespace {

// The hinged box's box: a 300 x 250 x 200 mm box with its 12 edges and 6 faces.
constexpr const char* kBoxPoints =
    R"(c000: [0, 0, 0], c100: [300, 0, 0], c110: [300, 250, 0], c010: [0, 250, 0],
             c001: [0, 0, 200], c101: [300, 0, 200], c111: [300, 250, 200], c011: [0, 250, 200])";
constexpr const char* kBoxFaces = R"(
      bottom: [c000, c010, c110, c100]
      top: [c001, c101, c111, c011]
      front: [c000, c100, c101, c001]
      back: [c110, c010, c011, c111]
      left: [c010, c000, c001, c011]
      right: [c100, c110, c111, c101])";

// The box alone, with a wire across it.
ConstraintGraph Box() {
  return LoadModelFromString(std::string(R"(
name: box
units: {length: mm}
components:
  box:
    points: {)") + kBoxPoints + R"(}
    edges: {wire: [c000, c111]}
    faces:)" + kBoxFaces + "\n",
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

// The box with a smaller block standing on its top, each face its own: seen from around, each
// hides parts of the other's edges.
ConstraintGraph BoxAndBlock() {
  return LoadModelFromString(std::string(R"(
name: box_and_block
units: {length: mm}
components:
  box:
    points: {)") + kBoxPoints + R"(,
             d000: [100, 80, 200], d100: [180, 80, 200], d110: [180, 160, 200],
             d010: [100, 160, 200], d001: [100, 80, 320], d101: [180, 80, 320],
             d111: [180, 160, 320], d011: [100, 160, 320]}
    faces:)" + kBoxFaces + R"(
      block_top: [d001, d101, d111, d011]
      block_front: [d000, d100, d101, d001]
      block_back: [d110, d010, d011, d111]
      block_left: [d010, d000, d001, d011]
      block_right: [d100, d110, d111, d101]
)",
                             "box_and_block.yaml", ".");
}

// Whether the model's faces (other than those `edge` bounds) hide camera-frame point P, asked
// with a margin either way: +1 hidden by some face's image (by a pixel) and plane (by 2 mm in a
// metre), -1 clear of every face by as much, 0 too near a border to say.
int HiddenBeyondDoubt(const ConstraintGraph& g, const Values& v, const Camera& camera,
                      const ModelEdge& edge, const Eigen::Vector3d& P) {
  const Rigid3d& camera_from_box = v.poses[0];
  const Eigen::Vector2d p = camera.Project<double>(P);
  bool doubt = false;
  const auto& faces = g.components[0].faces;
  for (size_t f = 0; f < faces.size(); ++f) {
    if (std::find(edge.faces.begin(), edge.faces.end(), static_cast<int>(f)) != edge.faces.end()) {
      continue;
    }
    std::vector<Eigen::Vector3d> corners;
    for (int k : faces[f].loop) {
      corners.push_back(camera_from_box * g.components[0].points[k].position);
    }
    const Eigen::Vector3d n = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalized();
    const double t = n.dot(corners[0]) / n.dot(P);  // the plane meets the ray at t P
    // The image polygon (convex), and p's signed distance inside it (px).
    double inside = 1e9;
    double turn = 0;
    std::vector<Eigen::Vector2d> image;
    for (const Eigen::Vector3d& c : corners) image.push_back(camera.Project<double>(c));
    for (size_t k = 0; k < image.size(); ++k) {
      const Eigen::Vector2d d = image[(k + 1) % image.size()] - image[k];
      const Eigen::Vector2d e = image[(k + 2) % image.size()] - image[(k + 1) % image.size()];
      turn += d.x() * e.y() - d.y() * e.x();
    }
    for (size_t k = 0; k < image.size(); ++k) {
      const Eigen::Vector2d d = (image[(k + 1) % image.size()] - image[k]).normalized();
      const Eigen::Vector2d r = p - image[k];
      inside = std::min(inside, (turn > 0 ? 1 : -1) * (d.x() * r.y() - d.y() * r.x()));
    }
    const bool in_front = t > 0.01 && t < 1 - 2e-3, behind = t <= 0 || t >= 1 - 0.5e-3;
    if (inside > 1 && in_front) return 1;
    if (!(inside < -1 || behind)) doubt = true;
  }
  return doubt ? 0 : -1;
}

TEST_CASE("model edges: the hidden parts cut out, and only those", "[geometry]") {
  const ConstraintGraph g = BoxAndBlock();
  const std::vector<ModelEdge> edges = ModelEdges(g);
  Camera distorted = testing::Pinhole();
  distorted.distortion[0] = -0.2;  // k1: the faces' images no longer straight-sided
  distorted.distortion[1] = 0.05;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  Visibility occluding;
  occluding.occlusion = true;
  for (const Camera& camera : {testing::Pinhole(), distorted}) {
    int gaps = 0, runs_checked = 0;
    for (int trial = 0; trial < 60; ++trial) {
      // The box's centre 1.2-1.8 m before the camera, turned at random.
      const Eigen::Quaterniond q =
          Eigen::Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized();
      const Eigen::Vector3d centre(0.15, 0.125, 0.16);
      const Eigen::Vector3d at(0.1 * unit(rng), 0.1 * unit(rng), 1.5 + 0.3 * unit(rng));
      const Values v = At(g, Rigid3d(q, at - q * centre));
      std::map<int, std::vector<ProjectedEdge>> by_edge;
      for (const ProjectedEdge& e : VisibleEdges(g, edges, v, camera, occluding)) {
        by_edge[e.edge].push_back(e);
      }
      for (const auto& [index, parts] : by_edge) {
        const ModelEdge& edge = edges[index];
        const Eigen::Vector3d A = v.poses[0] * g.components[0].points[edge.a].position;
        const Eigen::Vector3d B = v.poses[0] * g.components[0].points[edge.b].position;
        const double length = (B - A).norm();
        // A visible part's inside (a sample step, 2 px, from its ends) is not hidden.
        for (const ProjectedEdge& part : parts) {
          const double pixels = (part.b - part.a).norm();
          if (pixels < 8) continue;
          for (double f = 3 / pixels; f <= 1 - 3 / pixels; f += 1 / pixels) {
            CHECK(HiddenBeyondDoubt(g, v, camera, edge, part.A + f * (part.B - part.A)) != 1);
          }
          ++runs_checked;
        }
        // And between two visible parts, the gap's inside is hidden.
        for (size_t k = 1; k < parts.size(); ++k) {
          const double u0 = (parts[k - 1].B - A).norm() / length;
          const double u1 = (parts[k].A - A).norm() / length;
          const double pixels = (parts[k].a - parts[k - 1].b).norm();
          if (pixels < 8) continue;
          ++gaps;
          for (double f = 3 / pixels; f <= 1 - 3 / pixels; f += 1 / pixels) {
            const double u = u0 + f * (u1 - u0);
            CHECK(HiddenBeyondDoubt(g, v, camera, edge, A + u * (B - A)) != -1);
          }
        }
      }
    }
    // Not vacuous: edges were cut, and many parts checked.
    CHECK(gaps >= 10);
    CHECK(runs_checked >= 300);
  }
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
