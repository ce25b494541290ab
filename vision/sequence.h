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

// The tracker's standard scenarios, for its tests, its benchmark and the demo: `graph` seen by
// StandardCamera() from 1.3 m, from above (elevation 0.6 rad) and a little to the side (azimuth
// 0.35 rad) of its root component's points' centroid, swaying ±9 cm across the view and ±5 cm
// in depth over 100 frames (up to 6 mm a frame) and turning 0.3 degrees a frame, every joint with
// limits swinging between 10 % and 90 % of its range (a joint without limits: ±0.5 about its
// nominal value) over 80 frames; 30 clutter lines and 12 blobs, noise 2 and blur 0.8. By name:
//   steady    just that;
//   fast      swept ±0.3 m across the view every 40 frames instead: the centre moves up to
//             29 px a frame (median about 20);
//   occluded  a bar 15 % of the image wide sweeping across, hiding up to half the edges;
//   clutter   150 clutter lines and 40 blobs;
//   jump      knocked 60 mm sideways halfway through (about 45 px), which no prediction
//             foresees: the tracker's search range must double.
// Throws std::invalid_argument for another name or a model without a rigid root.
SequenceSpec StandardSequence(const ConstraintGraph& graph, const std::string& name, int frames,
                              unsigned seed = 1);
std::vector<std::string> StandardSequenceNames();
// 640 x 480 pixels, f = 800 px, principal point at the centre, no distortion.
Camera StandardCamera();

struct SequenceFrame;

// The median image motion between consecutive frames (px): how far the root component's points
// move in the image from one frame to the next.
double MedianImageMotion(const ConstraintGraph& graph, const std::vector<SequenceFrame>& frames,
                         const Camera& camera);

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
