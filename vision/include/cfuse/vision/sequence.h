// Rendered image sequences with their ground truth, for the tracker's tests and benchmarks (and
// the demo): the model moving along a smooth trajectory, its joints swinging, rendered frame by
// frame (render.h) with fresh clutter and noise, an occluder or a hand crossing if asked, in
// either of the renderer's styles.
//
// Frame i places the model's root component at
//   camera_from_root(i) = (Exp(spin i) R0,  t0 + velocity i + wobble sin(2π i / wobble_period))
// (rotation vectors and translations in the camera frame, turning about the root's origin), and
// each joint named in `joints` at centre + amplitude sin(2π i / joint_period); forward
// kinematics places the rest. The same formulas at fractional i give the instants a shutter
// sees (motion blur).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/vision/render.h"

namespace cfuse {

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
  // A sudden displacement from frame `jump_frame` on (the object knocked, half a frame
  // before): the tracker's prediction misses it by that much.
  Eigen::Vector3d jump = Eigen::Vector3d::Zero();
  int jump_frame = -1;
  // A hand (render.h HandOccluder) reaching in front of the object: its palm, `hand_width`
  // across, moves from `hand_from` at frame 0 to `hand_to` at the middle frame and back to
  // hand_from at the last (sinusoidally; camera frame, m), its forearm trailing towards
  // hand_from. Width 0: none. Drawn sharp, in either style.
  Eigen::Vector3d hand_from = Eigen::Vector3d::Zero(), hand_to = Eigen::Vector3d::Zero();
  double hand_width = 0;  // m
  // The realistic style only. Motion blur: the shutter is open for this share of the frame
  // interval (0: no blur), centred on the frame's instant (the truth's, as for a camera stamping
  // its frames at mid-exposure), and the object is rendered at as many evenly spread instants
  // in it as keep consecutive ones within 2 px of each other in the image, at most
  // `shutter_samples`.
  double shutter = 0;
  int shutter_samples = 8;
  // The realistic style only. The background's sway, like a hand-held camera's: up to `shake`
  // px along each image axis and shake / 400 rad of turn, smooth sines of periods 37, 53 and 71
  // frames with phases from the seed.
  double shake = 0;
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
//             foresees: the tracker's search range must double;
//   hand      a hand (9 cm across the palm, 35 cm nearer the camera than the object) reaching
//             in from the lower right over the object's centre by the middle frame and back
//             out, hiding up to a third of the object.
// In the realistic style (render.h), the scenario's motion is the same, and the seed also
// chooses the look: the photographs and crops on the faces and behind (`photographs`; null or
// empty: procedural cards, made once for the sequence), a point light 1.2-1.8 m from the
// object high up behind it, near the mirror of the camera about the root's top (+z) face, so
// that the top and the lid carry the highlight (specular 0.35-0.8, shininess 15-60; ambient
// 0.4), motion blur with the shutter open half the frame interval, the background swaying 2 px,
// 8 clutter lines and 4 blobs (150 and 40 in `clutter`), read noise 2 and shot noise of gain
// 0.05.
// Throws InputError (its location left to the caller, who knows the file) for another name or a
// model without a rigid root.
SequenceSpec StandardSequence(const ConstraintGraph& graph, const std::string& name, int frames,
                              unsigned seed = 1, RenderStyle style = RenderStyle::kPlain,
                              std::shared_ptr<const std::vector<GrayImage>> photographs = nullptr);
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

// Throws InputError (its location left to the caller, who knows the file) as Render does, or for a
// joint the model does not have.
std::vector<SequenceFrame> RenderSequence(const ConstraintGraph& graph, const Camera& camera,
                                          const SequenceSpec& spec);

// The configuration of frame i alone (no rendering); at a fractional i, the instant between.
Values SequencePose(const ConstraintGraph& graph, const SequenceSpec& spec, double i);

}  // namespace cfuse
