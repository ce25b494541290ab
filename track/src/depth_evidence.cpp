#include "cfuse/track/depth_evidence.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "cfuse/kernel/measurements/point_on_plane.h"

namespace cfuse {
namespace {

// Whether `p` lies inside `outline` (even-odd rule: a face may be concave).
bool Inside(const std::vector<Eigen::Vector2d>& outline, const Eigen::Vector2d& p) {
  bool inside = false;
  for (size_t i = 0, j = outline.size() - 1; i < outline.size(); j = i++) {
    const Eigen::Vector2d& a = outline[i];
    const Eigen::Vector2d& b = outline[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside;
}

// A face placed in the camera's frame for one frame's samples: its plane there, and the box its
// outline covers on the plane z = 1 (a quick test before the outline's).
struct PlacedFace {
  int face = -1;
  Eigen::Vector3d normal, point;  // the plane in the camera's frame
  Eigen::Matrix3d camera_from_component_R;
  Eigen::Vector3d camera_from_component_t;
  Eigen::Vector2d lo, hi;
};

}  // namespace

std::vector<DepthFace> DepthFaces(const ConstraintGraph& graph) {
  std::vector<DepthFace> out;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    const Component& component = graph.components[c];
    if (!component.rigid) continue;
    for (const Face& face : component.faces) {
      if (face.loop.size() < 3) continue;
      // Newell's normal: the loop's area vector, right-handed outward.
      Eigen::Vector3d normal = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
      for (size_t i = 0; i < face.loop.size(); ++i) {
        const Eigen::Vector3d& a = component.points[face.loop[i]].position;
        const Eigen::Vector3d& b = component.points[face.loop[(i + 1) % face.loop.size()]].position;
        normal += a.cross(b);
        centre += a;
      }
      if (normal.norm() < 1e-12) continue;  // degenerate: no plane
      DepthFace f;
      f.component = static_cast<int>(c);
      f.normal = normal.normalized();
      centre /= static_cast<double>(face.loop.size());
      f.offset = f.normal.dot(centre);
      f.u = f.normal.unitOrthogonal();
      f.v = f.normal.cross(f.u);
      for (int p : face.loop) {
        const Eigen::Vector3d& x = component.points[p].position;
        f.outline.push_back({f.u.dot(x), f.v.dot(x)});
      }
      out.push_back(std::move(f));
    }
  }
  return out;
}

std::vector<DepthMatch> MatchDepth(const ConstraintGraph& graph,
                                   const std::vector<DepthFace>& faces, const Values& values,
                                   const DepthFrame& frame, const DepthOptions& options) {
  std::vector<DepthMatch> out;
  if (frame.width <= 0 || frame.height <= 0 || options.stride <= 0) return out;
  // The faces turned to the camera, with their outlines' boxes on z = 1; a face reaching behind
  // the camera gets no box test.
  std::vector<PlacedFace> placed;
  for (size_t f = 0; f < faces.size(); ++f) {
    const DepthFace& face = faces[f];
    const Component& component = graph.components[face.component];
    const Rigid3d& pose = values.poses[graph.blocks[component.block].index];
    PlacedFace p;
    p.face = static_cast<int>(f);
    p.camera_from_component_R = pose.RotationMatrix();
    p.camera_from_component_t = pose.translation;
    p.normal = p.camera_from_component_R * face.normal;
    p.point = p.camera_from_component_R * (face.normal * face.offset) + pose.translation;
    if (p.normal.dot(p.point) >= 0) continue;  // turned away (the camera at the origin)
    p.lo.setConstant(std::numeric_limits<double>::infinity());
    p.hi = -p.lo;
    bool behind = false;
    for (const Eigen::Vector2d& o : face.outline) {
      const Eigen::Vector3d x = p.camera_from_component_R *
                                    (face.u * o.x() + face.v * o.y() + face.normal * face.offset) +
                                pose.translation;
      if (x.z() <= 1e-3) {
        behind = true;
        break;
      }
      const Eigen::Vector2d n(x.x() / x.z(), x.y() / x.z());
      p.lo = p.lo.cwiseMin(n);
      p.hi = p.hi.cwiseMax(n);
    }
    if (behind) {
      p.lo.setConstant(-std::numeric_limits<double>::infinity());
      p.hi = -p.lo;
    }
    placed.push_back(p);
  }
  if (placed.empty()) return out;
  for (int row = options.stride / 2; row < frame.height; row += options.stride) {
    for (int col = options.stride / 2; col < frame.width; col += options.stride) {
      const Eigen::Vector3d point =
          frame.points[static_cast<size_t>(row) * frame.width + col].cast<double>();
      if (!(point.z() > 0) || !point.allFinite()) continue;
      const Eigen::Vector2d n(point.x() / point.z(), point.y() / point.z());
      const Eigen::Vector3d ray = point.normalized();
      // The nearest front face the line of sight meets: what the sensor saw there.
      double nearest = std::numeric_limits<double>::infinity();
      int hit = -1;
      for (size_t k = 0; k < placed.size(); ++k) {
        const PlacedFace& p = placed[k];
        if ((n.array() < p.lo.array()).any() || (n.array() > p.hi.array()).any()) continue;
        const double along = p.normal.dot(ray);
        if (along >= -1e-9) continue;
        const double s = p.normal.dot(p.point) / along;
        if (!(s > 0) || s >= nearest) continue;
        const DepthFace& face = faces[p.face];
        const Eigen::Vector3d in_component =
            p.camera_from_component_R.transpose() * (ray * s - p.camera_from_component_t);
        if (!Inside(face.outline, {face.u.dot(in_component), face.v.dot(in_component)})) continue;
        nearest = s;
        hit = static_cast<int>(k);
      }
      if (hit < 0) continue;
      const PlacedFace& p = placed[hit];
      const DepthFace& face = faces[p.face];
      const double distance = face.normal.dot(p.camera_from_component_R.transpose() *
                                              (point - p.camera_from_component_t)) -
                              face.offset;
      if (std::abs(distance) > options.max_distance) continue;
      out.push_back({p.face, graph.components[face.component].block, point, distance});
    }
  }
  if (options.max_points > 0 && static_cast<int>(out.size()) > options.max_points) {
    std::vector<DepthMatch> spread;
    const double step = static_cast<double>(out.size()) / options.max_points;
    for (int i = 0; i < options.max_points; ++i) {
      spread.push_back(out[static_cast<size_t>((i + 0.5) * step)]);
    }
    out = std::move(spread);
  }
  return out;
}

DepthAgreement AgreeDepth(const ConstraintGraph& graph, const std::vector<DepthFace>& faces,
                          const Values& values, const DepthFrame& frame,
                          const DepthOptions& options) {
  DepthOptions every = options;
  every.max_distance = std::numeric_limits<double>::infinity();
  every.max_points = 0;
  const std::vector<DepthMatch> all = MatchDepth(graph, faces, values, frame, every);
  // A sample further in front of its face than a face can be off (a hand, a tool) hides it
  // and says nothing of the pose; one behind it says the face is not there.
  DepthAgreement out;
  int inliers = 0;
  for (const DepthMatch& m : all) {
    if (m.distance > options.max_distance) continue;
    ++out.samples;
    inliers += std::abs(m.distance) <= options.inlier_distance;
  }
  if (out.samples > 0) out.share = static_cast<double>(inliers) / out.samples;
  return out;
}

Factor DepthFactor(const std::vector<DepthFace>& faces, const DepthMatch& match, double sigma) {
  const DepthFace& face = faces[match.face];
  Factor f;
  f.residual = std::make_shared<PointOnPlaneResidual>(face.normal, face.offset, match.point);
  f.blocks = {match.block};
  f.noise = Eigen::MatrixXd::Constant(1, 1, sigma * sigma);
  f.name = "depth";
  return f;
}

}  // namespace cfuse
