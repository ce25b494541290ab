// The image front end's commands (docs/formats.md "Images, segments and edges"):
//   cfuse segments IMAGE   straight segments detected in an image
//   cfuse project MODEL    the model's visible edges at a pose, as a camera sees them
//   cfuse render MODEL     a synthetic image of the model at a pose, with its true edges, or a
//                          whole tracking sequence with its true track
// Exit statuses as for every command (commands.h).
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace cfuse::cli {

struct SegmentsCommandOptions {
  std::string image;
  std::string roi;  // "x,y,w,h", empty: the whole image
  std::string detector = "lowe";
  std::string output;   // SEGMENTS.json; empty: stdout
  std::string overlay;  // OUT.png: the segments drawn on the image
};
int RunSegments(const SegmentsCommandOptions& options, std::ostream& out, std::ostream& err);

struct ProjectCommandOptions {
  std::string model;
  std::string camera;
  std::string pose;     // a results-format file: its `components` are read
  std::string output;   // EDGES.json; empty: stdout
  std::string overlay;  // OUT.png, drawn on `image`
  std::string image;
};
int RunProject(const ProjectCommandOptions& options, std::ostream& out, std::ostream& err);

struct RenderCommandOptions {
  std::string model;
  std::string camera;
  std::string pose;
  // A standard tracking sequence instead of one pose (cfuse/vision/sequence.h: steady, fast,
  // occluded, clutter, jump or hand): `output` is then a new directory, filled with
  // frame_NNNNN.png, truth.csv (the track format, cli/track_command.h) and init.json (frame 0's
  // poses); the sequence's own clutter, noise and blur apply.
  std::string sequence;
  int frames = 60;
  std::string output;  // IMAGE.png (required)
  std::string truth;   // EDGES.json of the visible edges, optional
  unsigned seed = 1;
  double noise = 2.0, blur = 0.8;
  int clutter_lines = 30, clutter_blobs = 12;
  // cfuse/vision/render.h's style: "plain" or "realistic". The realistic style prints `photographs`
  // (image files or directories) on the faces and behind them; none given: Debian's
  // visp-images-data photographs if installed, else procedural cards. `noise` is then the
  // sensor's read noise.
  std::string style = "plain";
  std::vector<std::string> photographs;
};
int RunRender(const RenderCommandOptions& options, std::ostream& out, std::ostream& err);

}  // namespace cfuse::cli
