#include "cfuse/geometry/model_edges.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>

namespace cfuse {
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
    const Eigen::Vector3d q = PointInCamera(graph, values, component, loop[(k + 1) % loop.size()]);
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
    for (const auto& [p, q] :
         {std::pair{-d[axis], (*a)[axis] - lo[axis]}, std::pair{d[axis], hi[axis] - (*a)[axis]}}) {
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

namespace {

// A face as the camera sees it: its corners in the camera frame, its unit normal, whether it
// shows its edges under `visibility`, and its image polygon.
struct SeenFace {
  int component = -1, index = -1;
  std::vector<Eigen::Vector3d> corners;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector2d> image;
  Eigen::Vector2d lo, hi;  // the image polygon's bounding box
  double width = 0;        // px: twice its image's area over its perimeter
  bool front = false;      // faces the camera at all
  bool shows = false;      // and shows its edges (facing and width)
  // (`image` is filled for back faces too: they hide what lies behind them)
};

SeenFace See(const ConstraintGraph& graph, int component, int face, const Values& values,
             const Camera& camera, const Visibility& visibility) {
  SeenFace s;
  s.component = component;
  s.index = face;
  const std::vector<int>& loop = graph.components[component].faces[face].loop;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int k : loop) {
    s.corners.push_back(PointInCamera(graph, values, component, k));
    centre += s.corners.back();
  }
  centre /= static_cast<double>(std::max<size_t>(1, loop.size()));
  for (size_t k = 0; k < s.corners.size(); ++k) {
    s.normal += s.corners[k].cross(s.corners[(k + 1) % s.corners.size()]);
  }
  if (s.normal.norm() == 0) return s;
  s.normal.normalize();
  const Eigen::Vector3d towards = camera.model == Camera::Model::kOrthographic
                                      ? Eigen::Vector3d(0, 0, -1)
                                      : Eigen::Vector3d(-centre.normalized());
  const double facing = s.normal.dot(towards);
  s.front = facing > 0;
  s.shows = s.front && facing >= visibility.min_facing;
  bool finite = true;
  for (const Eigen::Vector3d& p : s.corners) {
    const Eigen::Vector2d uv = camera.Project<double>(p);
    finite = finite && uv.allFinite();
    s.image.push_back(uv);
  }
  if (!finite) {
    s.image.clear();
    return s;
  }
  s.lo = s.hi = s.image[0];
  for (const Eigen::Vector2d& p : s.image) {
    s.lo = s.lo.cwiseMin(p);
    s.hi = s.hi.cwiseMax(p);
  }
  if (s.front && visibility.min_face_width > 0) {
    double area = 0, perimeter = 0;
    for (size_t k = 0; k < s.image.size(); ++k) {
      const Eigen::Vector2d& a = s.image[k];
      const Eigen::Vector2d& b = s.image[(k + 1) % s.image.size()];
      area += a.x() * b.y() - a.y() * b.x();
      perimeter += (b - a).norm();
    }
    s.width = perimeter > 0 ? std::abs(area) / perimeter : 0;
    s.shows = s.shows && s.width >= visibility.min_face_width;
  }
  return s;
}

bool InsidePolygon(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p) {
  bool inside = false;
  for (size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Eigen::Vector2d &a = polygon[i], &b = polygon[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside;
}

// Whether face f lies in front of camera-frame point P (on the ray through P, nearer).
// `margin`: a share of P's depth (pinhole) or an absolute depth (orthographic, metres) the face
// must be nearer by.
bool InFront(const SeenFace& f, const Eigen::Vector3d& P, const Camera& camera,
             double margin = 1e-6) {
  if (camera.model == Camera::Model::kOrthographic) {
    if (std::abs(f.normal.z()) < 1e-12) return false;
    const double z =
        (f.normal.dot(f.corners[0]) - f.normal.x() * P.x() - f.normal.y() * P.y()) / f.normal.z();
    return z < P.z() - margin * std::abs(P.z()) - 1e-9;
  }
  const double along = f.normal.dot(P);
  if (std::abs(along) < 1e-12) return false;
  const double t = f.normal.dot(f.corners[0]) / along;  // the plane meets the ray at t P
  return t > 0 && t < 1 - margin;
}

// The runs of edge A-B (camera frame), between fractions s0 and s1, that no face hides: the
// edge sampled every 2 px of its image (at least 16 times), each sample hidden when it lies
// inside a face's image and behind the face's plane by more than a millimetre in a metre
// (a face meeting the edge at a corner does not hide it). The faces the edge bounds are skipped.
// A run's ends lie halfway between its last sample and the first hidden one.
std::vector<std::pair<double, double>> UnhiddenRuns(const ModelEdge& e,
                                                    const std::vector<const SeenFace*>& faces,
                                                    const Eigen::Vector3d& A,
                                                    const Eigen::Vector3d& B, double s0, double s1,
                                                    double image_length, const Camera& camera) {
  std::vector<const SeenFace*> hiding;
  for (const SeenFace* f : faces) {
    if (f->component == e.component &&
        std::find(e.faces.begin(), e.faces.end(), f->index) != e.faces.end()) {
      continue;
    }
    hiding.push_back(f);
  }
  // A face whose plane lies beyond the whole edge, or behind the camera along every ray through
  // it, hides none of its samples: the plane's ray parameter is monotone along the edge when the
  // edge stays on one side of the plane through the camera. Dropped with a margin far above
  // rounding, so that each sample's own test would have said the same.
  if (camera.model == Camera::Model::kPinhole) {
    const Eigen::Vector3d P0 = A + s0 * (B - A), P1 = A + s1 * (B - A);
    std::erase_if(hiding, [&](const SeenFace* f) {
      const double at0 = f->normal.dot(P0), at1 = f->normal.dot(P1);
      const double least = std::min(std::abs(at0), std::abs(at1));
      if ((at0 > 0) != (at1 > 0) || least < 1e-9) return false;
      const double plane = f->normal.dot(f->corners[0]);
      const double t0 = plane / at0, t1 = plane / at1;
      const double slack = 1e-6 * (1 + std::abs(plane) / least);
      return std::max(t0, t1) < -slack || std::min(t0, t1) > 1 - 1e-3 + slack;
    });
    // Without distortion the samples' images lie on the segment between the ends' images: a
    // face whose image box misses the segment's box contains none of them.
    if (!camera.Distorted() && P0.z() > 0 && P1.z() > 0) {
      const Eigen::Vector2d p0 = camera.Project<double>(P0), p1 = camera.Project<double>(P1);
      const Eigen::Vector2d lo = p0.cwiseMin(p1).array() - 1e-6;
      const Eigen::Vector2d hi = p0.cwiseMax(p1).array() + 1e-6;
      std::erase_if(hiding, [&](const SeenFace* f) {
        return f->hi.x() < lo.x() || f->lo.x() > hi.x() || f->hi.y() < lo.y() || f->lo.y() > hi.y();
      });
    }
  }
  if (hiding.empty()) return {{s0, s1}};
  const int n = std::max(16, static_cast<int>(std::ceil(image_length / 2)));
  std::vector<std::pair<double, double>> runs;
  double start = -1, last_seen = -1;
  for (int k = 0; k <= n; ++k) {
    const double u = s0 + (s1 - s0) * k / n;
    const Eigen::Vector3d P = A + u * (B - A);
    const Eigen::Vector2d p = camera.Project<double>(P);
    const bool hidden =
        p.allFinite() && std::any_of(hiding.begin(), hiding.end(), [&](const SeenFace* f) {
          return f->lo.x() <= p.x() && p.x() <= f->hi.x() && f->lo.y() <= p.y() &&
                 p.y() <= f->hi.y() && InsidePolygon(f->image, p) && InFront(*f, P, camera, 1e-3);
        });
    if (!hidden) {
      if (start < 0) start = k == 0 ? u : u - 0.5 * (s1 - s0) / n;
      last_seen = u;
    } else if (start >= 0) {
      runs.push_back({start, last_seen + 0.5 * (s1 - s0) / n});
      start = -1;
    }
  }
  if (start >= 0) runs.push_back({start, s1});
  return runs;
}

}  // namespace

std::vector<ProjectedEdge> VisibleEdges(const ConstraintGraph& graph,
                                        const std::vector<ModelEdge>& edges, const Values& values,
                                        const Camera& camera, const Visibility& visibility) {
  std::vector<ProjectedEdge> out;
  // Every face, seen once.
  std::map<std::pair<int, int>, SeenFace> seen;
  std::vector<const SeenFace*> faces;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (!graph.components[c].rigid) continue;
    for (size_t f = 0; f < graph.components[c].faces.size(); ++f) {
      const auto key = std::make_pair(static_cast<int>(c), static_cast<int>(f));
      SeenFace& s = seen.emplace(key, See(graph, static_cast<int>(c), static_cast<int>(f), values,
                                          camera, visibility))
                        .first->second;
      // Every face hides what lies behind it, a back face too: an open model's inner walls
      // (a tower without a roof) are seen from behind.
      if (s.image.size() >= 3) faces.push_back(&s);
    }
  }
  const Eigen::Vector2d lo(-0.5, -0.5);
  const Eigen::Vector2d hi(camera.width > 0 ? camera.width - 0.5 : 1e9,
                           camera.height > 0 ? camera.height - 0.5 : 1e9);
  for (size_t i = 0; i < edges.size(); ++i) {
    const ModelEdge& e = edges[i];
    // A front face too thin to show (seen nearly edge-on, a plate's rim) puts its two long
    // edges within its width of each other, and a line there could be either. The outer one,
    // against a back face or nothing, is the object's silhouette, the step the image shows
    // best: it is kept; the inner one, against a face that shows, is left out.
    const auto shows = [&](int f) { return seen.at({e.component, f}).shows; };
    const auto thin = [&](int f) {
      const SeenFace& face = seen.at({e.component, f});
      return face.front && !face.shows;
    };
    const bool any_thin = std::any_of(e.faces.begin(), e.faces.end(), thin);
    const bool any_shows = std::any_of(e.faces.begin(), e.faces.end(), shows);
    if (!e.faces.empty()) {
      if (visibility.min_face_width > 0 && any_thin) {
        if (any_shows) continue;
      } else if (!any_shows) {
        continue;
      }
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
    if (!visibility.occlusion) {
      out.push_back({static_cast<int>(i), A + s0 * (B - A), A + s1 * (B - A), a, b});
      continue;
    }
    for (const auto& [u0, u1] : UnhiddenRuns(e, faces, A, B, s0, s1, (b - a).norm(), camera)) {
      out.push_back({static_cast<int>(i), A + u0 * (B - A), A + u1 * (B - A), a0 + u0 * (b0 - a0),
                     a0 + u1 * (b0 - a0)});
    }
  }
  return out;
}

}  // namespace cfuse
