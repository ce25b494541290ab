#include "vision/model_edges.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>

namespace cfuse::vision {
namespace {

constexpr double kNearPlane = 1e-3;  // m: a pinhole camera sees only beyond it

Eigen::Vector3d PointInCamera(const ConstraintGraph& g, const Values& values, int component,
                              int point) {
  const Component& c = g.components[component];
  return values.poses[g.blocks[c.block].index] * c.points[point].position;
}

}  // namespace

std::vector<ModelEdge> ModelEdges(const ConstraintGraph& graph) {
  std::vector<ModelEdge> out;
  for (size_t ci = 0; ci < graph.components.size(); ++ci) {
    const Component& c = graph.components[ci];
    if (!c.rigid) continue;
    std::map<std::pair<int, int>, size_t> known;  // undirected (min, max) -> index in out
    auto add = [&](int a, int b, const std::string& name) -> ModelEdge& {
      const std::pair<int, int> key(std::min(a, b), std::max(a, b));
      if (auto it = known.find(key); it != known.end()) return out[it->second];
      known.emplace(key, out.size());
      out.push_back({static_cast<int>(ci), a, b, {}, name});
      return out.back();
    };
    for (const Edge& e : c.edges) add(e.a, e.b, e.name);
    for (size_t f = 0; f < c.faces.size(); ++f) {
      const std::vector<int>& loop = c.faces[f].loop;
      for (size_t k = 0; k < loop.size(); ++k) {
        const int a = loop[k], b = loop[(k + 1) % loop.size()];
        if (a == b) continue;
        ModelEdge& e = add(a, b, fmt::format("{}.side{}", c.faces[f].name, k));
        if (std::find(e.faces.begin(), e.faces.end(), static_cast<int>(f)) == e.faces.end()) {
          e.faces.push_back(static_cast<int>(f));
        }
      }
    }
  }
  return out;
}

bool FrontFacing(const ConstraintGraph& graph, int component, int face, const Values& values,
                 const Camera& camera) {
  const std::vector<int>& loop = graph.components[component].faces[face].loop;
  // Σ p_k × p_k+1: twice the area times the normal (right-hand rule), for any planar polygon,
  // convex or not.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < loop.size(); ++k) {
    const Eigen::Vector3d p = PointInCamera(graph, values, component, loop[k]);
    const Eigen::Vector3d q =
        PointInCamera(graph, values, component, loop[(k + 1) % loop.size()]);
    normal += p.cross(q);
    centre += p;
  }
  centre /= static_cast<double>(std::max<size_t>(1, loop.size()));
  if (camera.model == Camera::Model::kOrthographic) return normal.z() < 0;
  return normal.dot(-centre) > 0;
}

bool ClipToRectangle(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, Eigen::Vector2d* a,
                     Eigen::Vector2d* b) {
  const Eigen::Vector2d d = *b - *a;
  double t0 = 0, t1 = 1;
  for (int axis = 0; axis < 2; ++axis) {
    for (const auto& [p, q] : {std::pair{-d[axis], (*a)[axis] - lo[axis]},
                               std::pair{d[axis], hi[axis] - (*a)[axis]}}) {
      if (p == 0) {
        if (q < 0) return false;
        continue;
      }
      const double t = q / p;
      if (p < 0) {
        if (t > t1) return false;
        t0 = std::max(t0, t);
      } else {
        if (t < t0) return false;
        t1 = std::min(t1, t);
      }
    }
  }
  const Eigen::Vector2d start = *a;
  *a = start + t0 * d;
  *b = start + t1 * d;
  return true;
}

std::vector<ProjectedEdge> VisibleEdges(const ConstraintGraph& graph,
                                        const std::vector<ModelEdge>& edges, const Values& values,
                                        const Camera& camera) {
  std::vector<ProjectedEdge> out;
  // Front-facing, per (component, face), computed once.
  std::map<std::pair<int, int>, bool> front;
  auto faces_camera = [&](int component, int face) {
    const auto key = std::make_pair(component, face);
    auto it = front.find(key);
    if (it == front.end()) {
      it = front.emplace(key, FrontFacing(graph, component, face, values, camera)).first;
    }
    return it->second;
  };
  const Eigen::Vector2d lo(-0.5, -0.5);
  const Eigen::Vector2d hi(camera.width > 0 ? camera.width - 0.5 : 1e9,
                           camera.height > 0 ? camera.height - 0.5 : 1e9);
  for (size_t i = 0; i < edges.size(); ++i) {
    const ModelEdge& e = edges[i];
    if (!e.faces.empty() && std::none_of(e.faces.begin(), e.faces.end(), [&](int f) {
          return faces_camera(e.component, f);
        })) {
      continue;
    }
    Eigen::Vector3d A = PointInCamera(graph, values, e.component, e.a);
    Eigen::Vector3d B = PointInCamera(graph, values, e.component, e.b);
    if (camera.model == Camera::Model::kPinhole) {
      if (A.z() < kNearPlane && B.z() < kNearPlane) continue;
      if (A.z() < kNearPlane) A = B + (A - B) * ((B.z() - kNearPlane) / (B.z() - A.z()));
      if (B.z() < kNearPlane) B = A + (B - A) * ((A.z() - kNearPlane) / (A.z() - B.z()));
    }
    Eigen::Vector2d a = camera.Project<double>(A), b = camera.Project<double>(B);
    if (!a.allFinite() || !b.allFinite()) continue;
    const Eigen::Vector2d a0 = a, b0 = b;
    if (!ClipToRectangle(lo, hi, &a, &b)) continue;
    // The 3D part that is left, by the same fractions along the edge (exact for an
    // orthographic camera, the chord's approximation for a pinhole one).
    const double length = (b0 - a0).norm();
    const double s0 = length > 0 ? (a - a0).norm() / length : 0;
    const double s1 = length > 0 ? (b - a0).norm() / length : 1;
    out.push_back({static_cast<int>(i), A + s0 * (B - A), A + s1 * (B - A), a, b});
  }
  return out;
}

}  // namespace cfuse::vision
