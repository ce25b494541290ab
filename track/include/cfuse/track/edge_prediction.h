// The model's edges as a predicted state shows them: where each visible piece lies in the image
// and how uncertain that is (Lowe 1992, equation 2: S = A P Aᵀ for the perpendicular position of
// the piece's two ends, from the kernel's prediction of an image-segment residual).
//
// Frames: a piece's ends A, B are in its component's coordinates (so that a residual can move
// them with the component's pose); its image ends a, b in pixels. a -> b follows the model
// edge's own order of points and the normal is n = (-dir.y, dir.x) (the image-segment
// residual's, cfuse/kernel/measurements/image_segment.h), so that the side a normal points to stays
// the same side of the edge from frame to frame.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/measurements/camera.h"

namespace cfuse {

struct EdgeModel {
  int edge = -1;         // index into ModelEdges()
  int block = -1;        // its component's pose block
  Eigen::Vector3d A, B;  // the visible piece's ends, component coordinates
  Eigen::Vector2d a, b;  // its image, pixels
  Eigen::Vector2d mid, dir, normal;
  double length = 0, orientation = 0;
  double t0 = 0, t1 = 1;  // the piece's ends as fractions along the whole model edge
  // On the outline of its component: one of its faces turned to the camera and the other away
  // (or none: a face's free side); the object against whatever lies behind it.
  bool silhouette = false;
  // The covariance of the perpendicular position of a and of b (prediction only, px²).
  double var_a = 0, var_b = 0, cov_ab = 0;
  double sigma_x = 0, sigma_y = 0;  // midpoint across (px) and angle (rad), noise included
  // px: a measured end's error across the edge: the model's and the camera's.
  double noise = 1;

  // The standard deviation of the perpendicular position at fraction u of the piece (0 at a).
  double SigmaAt(double u) const;
};

// The image-segment factor of edge `e` measured by the line through p and q, with the
// covariance `noise` of p's and q's distances from the projected edge.
Factor EdgeFactor(const Camera& camera, const EdgeModel& e, const Eigen::Vector2d& p,
                  const Eigen::Vector2d& q, const Eigen::Matrix2d& noise);

// Fills the edge's variances from `state` and the pixel noise `e->noise`. False when the
// prediction is not finite (an end behind the camera).
bool PredictVariance(const Camera& camera, const GaussianState& state, EdgeModel* e);

// The visible pieces at `state`'s mean (VisibleEdges with `visibility`), those at least
// `min_pixels` long, with their variances.
std::vector<EdgeModel> PredictEdges(const ConstraintGraph& graph,
                                    const std::vector<ModelEdge>& edges,
                                    const GaussianState& state, const Camera& camera,
                                    const Visibility& visibility, double pixel_sigma,
                                    double min_pixels);

// Each piece where `state` projects its ends, with that state's variances: the edges as a
// tightened prediction shows them.
void Reproject(const ConstraintGraph& graph, const Camera& camera, const GaussianState& state,
               std::vector<EdgeModel>* edges);

}  // namespace cfuse
