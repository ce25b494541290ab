// A baseline for detection (bench only): oriented chamfer matching of the model's edges over a
// grid of poses, on OpenCV's distance transforms of the image's Canny edges, the best poses
// refined on the same score and handed to the detector's own tracking and decision
// (cfuse::DetectFrom), so that only the generation of hypotheses differs from `cfuse detect`.
//
// The grid: viewing directions spread evenly over the whole sphere (Fibonacci), turns about the
// line of sight and image sizes of the model. Each direction's edges are projected once, the
// object's centre on the optical axis (the templates); a turn about the optical axis and a change
// of depth are then a rotation and a scaling of that image about the principal point, and a
// place elsewhere in the image a translation of it (an approximation off the axis, which the
// refinement and the tracker absorb). A template at an image place is scored by what its samples
// explain beyond chance: each sample's nearness 1 - d / truncate to the nearest image edge of
// about its orientation (within one bin of `bins` over 180 degrees), less that nearness's mean
// over the image. The sum, not the mean: a mean lets small outlines win in busy corners.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/vision/segments.h"

namespace cfuse::bench {

struct ChamferOptions {
  int directions = 120;  // over the whole sphere, about 19 degrees apart
  int turns = 20;        // about the line of sight
  std::vector<double> sizes = {100, 150, 225, 340, 510, 760};  // px across the model
  int position_step = 12;   // px between the image places of the coarse pass
  int bins = 8;             // edge orientations over 180 degrees
  double truncate = 15;     // px
  double sample_step = 4;   // px between a template's samples at the reference size
  int coarse_samples = 24;  // per template in the coarse pass
  int kept = 3000;          // placements of the coarse pass rescored with every sample
  int candidates = 12;      // the best, spread apart, refined and tracked
  double spread_pixels = 10;
  double min_inside = 0.6;  // of a placement's samples inside the image
  double canny_low = 40, canny_high = 120;
};

struct ChamferStats {
  double edges_ms = 0, matching_ms = 0, refinement_ms = 0;
  long placements = 0;  // template placements scored in the coarse pass
};

class ChamferBaseline {
 public:
  // The templates (the "training"): `directions` projections of the model.
  ChamferBaseline(const ConstraintGraph& graph, const Camera& camera, ChamferOptions options = {});

  // The best poses of the model in `image`, best first.
  std::vector<Values> Candidates(const GrayView& image, ChamferStats* stats) const;

  // What `values` explains of `image` by the baseline's score (for diagnostics).
  double Evidence(const GrayView& image, const Values& values) const;

  double training_ms() const { return training_ms_; }
  int templates() const { return static_cast<int>(templates_.size()); }

 private:
  struct Template {
    Eigen::Matrix3d camera_from_object;  // rotation; the centre on the axis at depth_
    // Per sample: px from the projected centre at the reference size, and the edge's normal
    // direction (radians); edge after edge.
    std::vector<Eigen::Vector3f> samples;
  };

  double PoseEvidence(const std::vector<cv::Mat>& evidence, const Values& values) const;
  Values Posed(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& centre_in_camera) const;

  const ConstraintGraph& graph_;  // outlives this
  Camera camera_;
  ChamferOptions options_;
  std::vector<ModelEdge> edges_;
  Eigen::Vector3d centre_;     // the model's points' mean, in the root's nominal frame
  double diameter_ = 1;        // m: twice the largest distance of a point from the centre
  double depth_ = 1;           // m: the templates' depth
  double reference_size_ = 1;  // px: the model's diameter at depth_
  std::vector<Template> templates_;
  double training_ms_ = 0;
};

}  // namespace cfuse::bench
