// A model's edges as a camera sees them at a configuration: what the tracker predicts and what
// `cfuse project` draws.
//
// The edges of a rigid component are its `edges` and the sides of its `faces` (each undirected
// edge once). A face is front-facing when its outward normal (right-hand rule on its loop) has
// a positive component towards the camera: towards the camera centre for a pinhole camera,
// along -z for an orthographic one. An edge with faces is visible when one of its faces is
// front-facing; an edge with none (a wire) always is. A visible edge is clipped to the space in
// front of a pinhole camera (z >= 1 mm), projected at its two ends (lens distortion bends a long
// edge slightly; its chord is drawn), and clipped to the image, [-0.5, width - 0.5] x [-0.5,
// height - 0.5]. With Visibility::occlusion, hidden lines are removed too: an edge is cut into
// the pieces that no face of any component (its own included, front or back) hides, as ViSP's
// scan-line visibility test does; the renderer (render.h) uses a depth buffer instead.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/measurements/camera.h"

namespace cfuse {

// One edge of a rigid component: its two feature points (indices into Component::points) and
// the faces it bounds.
struct ModelEdge {
  int component = -1;
  int a = -1, b = -1;
  std::vector<int> faces;  // indices into Component::faces
  std::string name;        // the edge's name, or "FACE.side<k>" for a face's side
};

// Every edge of every rigid component, in model order: named edges first, then face sides
// that are no named edge.
std::vector<ModelEdge> ModelEdges(const ConstraintGraph& graph);

struct ProjectedEdge {
  int edge = -1;         // index into ModelEdges()
  Eigen::Vector3d A, B;  // its visible part in the camera frame, metres
  Eigen::Vector2d a, b;  // the same projected and clipped to the image, pixels
};

// Stricter visibility, for matching (the tracker): a face shows its edges only when it turns
// towards the camera by at least `min_facing` (the cosine of its normal with the direction to
// the camera) and its image is at least `min_face_width` pixels across (twice its area over its
// perimeter): a face seen nearly edge-on, or a thin plate's rim, puts its edges within a pixel
// or two of each other, and a segment there could be either: of a front face too thin to show,
// the edge it shares with a face that shows is left out, and its outer edge (the silhouette,
// against a back face or nothing) is kept. With `occlusion`, edges are cut
// into the pieces no face hides (several ProjectedEdges may then share one `edge`).
struct Visibility {
  double min_facing = 0;
  double min_face_width = 0;  // px
  bool occlusion = false;
};

// The visible edges at `values` (camera frame = world frame, as for image measurements).
std::vector<ProjectedEdge> VisibleEdges(const ConstraintGraph& graph,
                                        const std::vector<ModelEdge>& edges, const Values& values,
                                        const Camera& camera, const Visibility& visibility = {});

// Whether face `face` of rigid component `component` faces the camera at `values`.
bool FrontFacing(const ConstraintGraph& graph, int component, int face, const Values& values,
                 const Camera& camera);

// Clips the segment a-b to the rectangle [lo, hi] (Liang-Barsky); false when nothing is left.
bool ClipToRectangle(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, Eigen::Vector2d* a,
                     Eigen::Vector2d* b);

}  // namespace cfuse
