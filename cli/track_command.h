// `cfuse track`: a model tracked through an image sequence (cfuse/track/tracker.h), and the track
// file it writes (docs/formats.md "Tracks"):
//
//   cfuse track MODEL --camera CAM --images 'frames/*.png' --init POSE.json
//               [-o TRACK.csv] [--overlay DIR] [--max-branches N]
//               [--depth 'depth/*.bin' --depth-camera CAM [--depth-pose depth_M_color.txt]
//                [--depth-scale S] [--depth-distortion k1,k2,p1,p2,k3]]
//
// --images is a glob (wildcards in the file name only), a directory (its images, sorted), or a
// video file. A frame that cannot be read is reported and skipped, and the track goes on
// across it; the command then exits 2 after writing everything else (nothing, when no frame could
// be read). Exit statuses as for every command (commands.h): 1 when no frame was verified.
//
// The frames must be of the camera's image size; a camera that gives none (ViSP's tracker
// settings) takes the first frame's, and a later frame of another size is skipped. --init is a
// results-format pose file, or ViSP's pose of the object in a `.pos` file (cfuse/importers/visp.h).
//
// With --depth, each frame's depth file is read with it and its points fused with the edges
// (Tracker::Track(image, depth)); there must be as many depth files as frames, and a frame whose
// depth file cannot be read is skipped as an unreadable image is.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/values.h"
#include "cfuse/track/tracker.h"

namespace cfuse::cli {

struct TrackCommandOptions {
  std::string model;
  std::string camera;
  std::string images;   // glob, directory or video file
  std::string init;     // results-format poses at the first frame, or a ViSP .pos; empty: detected
  std::string output;   // TRACK.csv; empty: stdout (and the summary to stderr)
  std::string overlay;  // directory for the overlay frames (created if missing)
  int max_branches = 5;
  // A range sensor's frames, one a frame in order: a glob or a directory of raw depth files
  // (`.bin`, ViSP's RGB-D examples') or 16-bit images; empty: none. Their camera (any camera
  // file; its pinhole), its pose as ViSP writes depth_M_color (a 4x4 matrix file: the grey
  // camera's pose in the depth camera's frame; empty: the same camera), metres per depth unit,
  // and RealSense's deprojection coefficients k1, k2, p1, p2, k3 (cfuse/vision/depth_file.h).
  std::string depth, depth_camera, depth_pose;
  double depth_scale = 0.001;
  std::vector<double> depth_distortion;
  bool progress = false;  // a progress bar on `err` (set when it is a terminal)
};
int RunTrack(const TrackCommandOptions& options, std::ostream& out, std::ostream& err);

// The track file's header and rows: frame, time_ms, verified, then each rigid component's pose
// in the camera frame (NAME.x, .y, .z in metres, NAME.qw, .qx, .qy, .qz), then each joint's
// value under its name (radians or metres); with the fit (`cfuse track`), the share of the
// visible outline the image supports and the position sigma in millimetres
// (Verification::share, TrackedFrame::position_sigma). `cfuse render --sequence`
// writes its truth so, without the fit.
std::string TrackCsvHeader(const ConstraintGraph& graph, bool fit = false);
std::string TrackCsvRow(const ConstraintGraph& graph, int frame, double time_ms, bool verified,
                        const Values& values, const TrackedFrame* fit = nullptr);

}  // namespace cfuse::cli
