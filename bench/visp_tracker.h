// ViSP's model-based edge tracker as a peer in the tracking benchmark: the same rendered
// sequence, the same model (a CAO file), the same initial pose, tracked by ViSP's
// vpMbGenericTracker with edges only (vpMbGenericTracker::EDGE_TRACKER, Debian's libvisp-mbt).
//
//   std::vector<PeerFrame> track = TrackWithVisp(frames, 640, 480, camera,
//                                                "tests/data/cao/file_box.cao", truth0, {});
//
// ViSP's edge tracker (Comport, Marchand, Pressigout & Chaumette 2006) samples each visible
// model edge every `sample_step` pixels, searches along the edge's normal, `range` pixels
// either way, for the pixel whose oriented-mask convolution ("moving edges", vpMe) is largest
// and above `threshold`, then moves the pose by robust (Tukey M-estimator) virtual visual
// servoing until those distances are least. Frames come in order; each starts from the pose of
// the last, with no motion model: a frame step that moves the edges further than `range` loses
// the object.
//
// Conventions: the pose ViSP calls cMo is cfuse's camera_from_object (x_c = R x_o + t, camera
// frame x right, y down, z forward, metres); the camera's pixel u = fx x/z + cx with pixel
// centres at integer coordinates is ViSP's vpCameraParameters without distortion
// (initPersProjWithoutDistortion(px = fx, py = fy, u0 = cx, v0 = cy)). Images are 8-bit grey,
// row-major, width x height with no padding. ViSP's display stays off (no X server needed).
//
// This header names no ViSP type: only bench/visp_tracker.cpp includes ViSP, and only the
// cfuse_visp_peer library (built when CMake finds ViSP) links it.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse::bench {

// The tracker's settings. The defaults are ViSP's tutorial configuration for its edge tracker
// (tutorial/tracking/model-based/generic/tutorial-mb-generic-tracker-full.cpp and
// tutorial-mb-generic-tracker.cpp in ViSP 3.x, the tea box at 640 x 480, f ≈ 840 px): the
// moving edges' mask size 5, 180 masks, range 8, threshold 10000, mu1 = mu2 = 0.5, sample step
// 4; faces appearing at 70° and disappearing at 80° from the line of sight; near and far
// clipping at 0.1 m and 100 m plus the field of view; no scan-line visibility test (ViSP's
// default: on these sequences it makes the edge tracker four times slower and no better); at least
// 20 % of the moving edges good (setGoodMovingEdgesRatioThreshold(0.2)).
struct VispOptions {
  // vpMe: the moving edges.
  int mask_size = 5;      // px, the oriented masks' size (odd)
  int mask_number = 180;  // orientations of the masks (180: every degree)
  int range = 8;          // px searched either side of an edge's predicted position
  // The mask response a moving edge needs, on ViSP 3.5's scale (later releases call it
  // OLD_THRESHOLD and divide it by 100 n floor(n / 2), n the mask size: 10 at n = 5).
  double threshold = 10000;
  double mu1 = 0.5;  // contrast ratio bounds to the previous frame's edge point
  double mu2 = 0.5;
  double sample_step = 4;  // px between samples along an edge
  // vpMbGenericTracker.
  double angle_appear_deg = 70;
  double angle_disappear_deg = 80;
  double near_clipping = 0.1;  // m
  double far_clipping = 100;   // m
  bool scanline_visibility = false;
  double good_moving_edges_ratio = 0.2;  // below this share of good edges, track() throws
  // A ViSP settings file (vpMbGenericTracker::loadConfigFile: moving edges, camera, face angles,
  // clipping), read after the fields above, which it overrides where it has them: a data set's own
  // settings, as ViSP's own tests read them. Empty: the fields alone.
  std::string config_file;
  // OpenMP threads ViSP's core may use; 1 keeps the timing comparable to a single-threaded
  // tracker (0: leave ViSP's default, all cores).
  int threads = 1;
};

struct PeerFrame {
  bool ok = false;  // track() did not throw and returned a finite pose
  double ms = 0;    // wall time of track() alone on this frame
  // ViSP's pose on this frame; on a frame that is not ok, the last good pose (the one the
  // tracker is re-initialised from).
  Rigid3d camera_from_object;
};

// Tracks `frames` (each width x height 8-bit grey pixels, row-major) with vpMbGenericTracker,
// edges only, its model read from `cao_path` (metres), starting at `initial` (camera_from_object
// at frames[0]): initFromPose on frames[0], then track() on every frame, frames[0] included, and
// getPose(). A frame on which ViSP throws (it does so when too few moving edges are good) is not
// ok, and the tracker is re-initialised there from the last good pose. Returns one PeerFrame per
// frame.
//
// Throws std::invalid_argument for a camera that is not a pinhole without distortion, a size
// that differs from the camera's (when the camera has one) or no frames; std::runtime_error
// when ViSP cannot read the model.
std::vector<PeerFrame> TrackWithVisp(const std::vector<const std::uint8_t*>& frames, int width,
                                     int height, const Camera& camera, const std::string& cao_path,
                                     const Rigid3d& initial, const VispOptions& options = {});

// A depth frame as a point cloud in the depth camera's frame (metres), row-major, width x height
// points; a point without depth is (0, 0, 0).
struct DepthCloud {
  int width = 0, height = 0;
  std::vector<Eigen::Vector3f> points;
};

// The same with ViSP's edges and its dense depth tracker together (vpMbGenericTracker with
// EDGE_TRACKER on the grey camera and DEPTH_DENSE_TRACKER on the depth camera, as ViSP's own
// examples track mbt-depth's sequences): far more accurate than edges alone, and independent of
// them, so a reference for sequences that have no truth. `depth_config` is the depth camera's
// settings file (its camera and sampling), `depth_from_color` the transform between the two
// cameras (ViSP's depth_M_color), `clouds` one per frame.
std::vector<PeerFrame> TrackWithVispDepth(const std::vector<const std::uint8_t*>& frames, int width,
                                          int height, const Camera& camera,
                                          const std::string& cao_path, const Rigid3d& initial,
                                          const VispOptions& options,
                                          const std::vector<DepthCloud>& clouds,
                                          const std::string& depth_config,
                                          const Rigid3d& depth_from_color);

}  // namespace cfuse::bench
