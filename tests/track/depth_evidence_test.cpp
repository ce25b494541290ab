// Depth evidence (cfuse/track/depth_evidence.h): the box of tests/data/cao/file_box.cao seen by a
// range sensor whose frames are ray-cast here by the slab method, independently of the polygon
// tests under test.
#include "cfuse/track/depth_evidence.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "cfuse/importers/cao.h"
#include "cfuse/kernel/evaluate.h"
#include "test_util.h"

namespace cfuse {
namespace {

constexpr int kWidth = 64, kHeight = 48;
constexpr double kFocal = 60, kBackground = 3;  // px; m, a wall behind the box

// The box (0..0.3 x 0..0.25 x 0..0.2 in its frame) at `camera_from_box`, seen by a pinhole of
// kWidth x kHeight; a line of sight that misses it meets the wall at z = kBackground. Pixels
// with x below `occluded_below` see an occluder 0.1 m nearer than whatever is behind it.
DepthFrame RayCast(const Rigid3d& camera_from_box, int occluded_below = 0) {
  DepthFrame frame;
  frame.width = kWidth;
  frame.height = kHeight;
  const Rigid3d box_from_camera = camera_from_box.Inverse();
  const Eigen::Vector3d lo(0, 0, 0), hi(0.3, 0.25, 0.2);
  for (int i = 0; i < kHeight; ++i) {
    for (int j = 0; j < kWidth; ++j) {
      const Eigen::Vector3d ray((j - kWidth / 2.0) / kFocal, (i - kHeight / 2.0) / kFocal, 1);
      const Eigen::Vector3d o = box_from_camera.translation;
      const Eigen::Vector3d d = box_from_camera.rotation * ray;
      double t0 = 0, t1 = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a) {
        const double u = (lo[a] - o[a]) / d[a], v = (hi[a] - o[a]) / d[a];
        t0 = std::max(t0, std::min(u, v));
        t1 = std::min(t1, std::max(u, v));
      }
      double t = t0 <= t1 ? t0 : kBackground;  // ray.z() == 1: t is the depth
      if (j < occluded_below) t -= 0.1;
      frame.points.push_back((ray * t).cast<float>());
    }
  }
  return frame;
}

struct Scene {
  ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  std::vector<DepthFace> faces = DepthFaces(graph);
  // The box 1.2 m away, turned so that three faces show.
  Rigid3d camera_from_box{Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()) *
                                             Eigen::AngleAxisd(-0.6, Eigen::Vector3d::UnitX())),
                          Eigen::Vector3d(-0.15, -0.1, 1.2)};
  Values At(const Rigid3d& pose) const {
    Values v = graph.nominal;
    v.poses[0] = pose * graph.nominal.poses[0];
    return v;
  }
};

TEST_CASE("depth: a model's faces as planes with outward normals", "[depth]") {
  const Scene s;
  REQUIRE(s.faces.size() == 6);
  // The top (z = 0.2, normal +z) and the bottom (z = 0, normal -z), in the file's order.
  CHECK(s.faces[1].normal.isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  CHECK(s.faces[1].offset == Approx(0.2));
  CHECK(s.faces[0].normal.isApprox(-Eigen::Vector3d::UnitZ(), 1e-12));
  CHECK(s.faces[0].offset == Approx(0).margin(1e-12));
  for (const DepthFace& f : s.faces) {
    CHECK(f.outline.size() == 4);
    CHECK(std::abs(f.u.dot(f.normal)) < 1e-12);
    CHECK(std::abs(f.v.dot(f.normal)) < 1e-12);
  }
}

TEST_CASE("depth: each sample on the face its line of sight meets, at its distance", "[depth]") {
  const Scene s;
  const DepthFrame frame = RayCast(s.camera_from_box);
  DepthOptions options;
  options.stride = 2;
  options.max_points = 0;
  // The samples that see the box, counted from the ray-cast frame.
  int on_box = 0;
  for (int i = options.stride / 2; i < kHeight; i += options.stride) {
    for (int j = options.stride / 2; j < kWidth; j += options.stride) {
      on_box += frame.points[i * kWidth + j].z() < kBackground - 0.01;
    }
  }
  REQUIRE(on_box > 50);
  const std::vector<DepthMatch> at_truth =
      MatchDepth(s.graph, s.faces, s.At(s.camera_from_box), frame, options);
  // Every sample of the box, but for one or two on an edge between faces or the outline.
  CHECK(static_cast<int>(at_truth.size()) >= on_box - 2);
  CHECK(static_cast<int>(at_truth.size()) <= on_box);
  std::vector<int> faces_seen;
  for (const DepthMatch& m : at_truth) {
    CHECK(std::abs(m.distance) < 1e-5);
    CHECK(m.block == 0);
    faces_seen.push_back(m.face);
  }
  std::sort(faces_seen.begin(), faces_seen.end());
  faces_seen.erase(std::unique(faces_seen.begin(), faces_seen.end()), faces_seen.end());
  CHECK(faces_seen.size() == 3);
  // The model 10 mm further away: every sample 10 mm in front of its face along the line of
  // sight, less along the face's normal.
  Rigid3d further = s.camera_from_box;
  further.translation.z() += 0.01;
  for (const DepthMatch& m : MatchDepth(s.graph, s.faces, s.At(further), frame, options)) {
    CHECK(m.distance > 0);
    CHECK(m.distance <= 0.01 + 1e-9);
  }
  // ... and 20 cm away: every sample beyond max_distance of the face its line of sight meets,
  // even on a face seen at a slant.
  further.translation.z() += 0.19;
  CHECK(MatchDepth(s.graph, s.faces, s.At(further), frame, options).empty());
  // At most max_points, spread over the image's rows.
  options.max_points = 10;
  const std::vector<DepthMatch> few =
      MatchDepth(s.graph, s.faces, s.At(s.camera_from_box), frame, options);
  REQUIRE(few.size() == 10);
  CHECK(few.back().point.y() / few.back().point.z() -
            few.front().point.y() / few.front().point.z() >
        0.5 * (at_truth.back().point.y() / at_truth.back().point.z() -
               at_truth.front().point.y() / at_truth.front().point.z()));
}

TEST_CASE("depth: the faces' agreement with the sensor, an occluder left out", "[depth]") {
  const Scene s;
  DepthOptions options;
  options.stride = 2;
  const DepthFrame frame = RayCast(s.camera_from_box);
  const DepthAgreement right =
      AgreeDepth(s.graph, s.faces, s.At(s.camera_from_box), frame, options);
  CHECK(right.samples > 50);
  CHECK(right.share > 0.97);
  // 15 mm deeper: the sensor's points lie in front of the faces, beyond inlier_distance.
  Rigid3d deeper = s.camera_from_box;
  deeper.translation.z() += 0.015;
  CHECK(AgreeDepth(s.graph, s.faces, s.At(deeper), frame, options).share < 0.05);
  // Slid 20 mm sideways: the faces cover the wall beside the box, and the box's sides.
  Rigid3d slid = s.camera_from_box;
  slid.translation.x() += 0.02;
  CHECK(AgreeDepth(s.graph, s.faces, s.At(slid), frame, options).share < options.min_inlier_share);
  // An occluder over the image's left half: its samples say nothing, the rest agree.
  const DepthFrame hidden = RayCast(s.camera_from_box, kWidth / 2);
  const DepthAgreement behind =
      AgreeDepth(s.graph, s.faces, s.At(s.camera_from_box), hidden, options);
  CHECK(behind.samples < right.samples);
  CHECK(behind.samples > 10);
  CHECK(behind.share > 0.97);
}

TEST_CASE("depth: a sample's factor is its distance from its face, in metres", "[depth]") {
  const Scene s;
  const DepthFrame frame = RayCast(s.camera_from_box);
  Rigid3d further = s.camera_from_box;
  further.translation.z() += 0.01;
  const Values at = s.At(further);
  const std::vector<DepthMatch> matches = MatchDepth(s.graph, s.faces, at, frame, {});
  REQUIRE_FALSE(matches.empty());
  Eigen::VectorXd r;
  for (const DepthMatch& m : matches) {
    const Factor f = DepthFactor(s.faces, m, 0.002);
    EvaluateResidual(*f.residual, s.graph.blocks, f.blocks, at, &r, nullptr);
    CHECK(r[0] == Approx(m.distance).margin(1e-9));
    CHECK(f.noise(0, 0) == Approx(4e-6));
  }
}

}  // namespace
}  // namespace cfuse
