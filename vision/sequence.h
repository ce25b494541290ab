// Rendered image sequences with their ground truth, for the tracker's tests and benchmarks (and
// the demo): the model moving along a smooth trajectory, its joints swinging, rendered frame by
// frame (render.h) with fresh clutter and noise, an occluder crossing if asked.
//
// Frame i places the model's root component at
//   camera_from_root(i) = (Exp(spin i) R0,  t0 + velocity i + wobble sin(2π i / wobble_period))
// (rotation vectors and translations in the camera frame, turning about the root's origin), and
// each joint named in `joints` at centre + amplitude sin(2π i / joint_period); forward
// kinematics places the rest.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "constraints/graph.h"
#include "kernel/measurements/camera.h"
#include "vision/render.h"

namespace cfuse::vision {

struct SequenceSpec {
  int frames = 60;
  Rigid3d start;                                            // camera_from_root at frame 0
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();       // m per frame
  Eigen::Vector3d spin = Eigen::Vector3d::Zero();           // rad per frame
  Eigen::Vector3d wobble = Eigen::Vector3d::Zero();         // m, amplitude
  double wobble_period = 40;                                // frames
  std::map<std::string, std::pair<double, double>> joints;  // name -> (centre, amplitude)
  double joint_period = 60;                                 // frames
  RenderOptions render;                                     // its seed advances by frame
  // A dark bar sweeping across the image, as wide as this share of the image's width (0: none),
  // from left to right over the sequence.
  double occluder_width = 0;
  // A sudden displacement from frame `jump_frame` on (the object knocked): the tracker's
  // prediction misses it by that much.
  Eigen::Vector3d jump = Eigen::Vector3d::Zero();
  int jump_frame = -1;
};

// camera_from_model for a camera looking at `target` (model coordinates) from `distance` away,
// at `azimuth` about the model's z axis from its -y side and `elevation` above its xy plane
// (radians), the image's up along the model's z.
Rigid3d LookAt(const Eigen::Vector3d& target, double azimuth, double elevation, double distance);

struct SequenceFrame {
  Values truth;         // every component's pose in the camera frame
  Rendering rendering;  // the image and its visible edges
};

// Throws std::invalid_argument as Render does, or for a joint the model does not have.
std::vector<SequenceFrame> RenderSequence(const ConstraintGraph& graph, const Camera& camera,
                                          const SequenceSpec& spec);

// The configuration of frame i alone (no rendering).
Values SequencePose(const ConstraintGraph& graph, const SequenceSpec& spec, int i);

}  // namespace cfuse::vision
