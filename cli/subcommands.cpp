// The subcommands of `cfuse`: each declares its options on CLI11's parser and returns what runs
// it once the command line is parsed (a Run*() function of commands.h, image_commands.h or
// track_command.h).
#include "cli/subcommands.h"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <memory>

#include "cli/commands.h"
#include "cli/image_commands.h"
#include "cli/detect_command.h"
#include "cli/track_command.h"

namespace cfuse::cli {
namespace {

std::function<int()> DeclareCheck(CLI::App* cmd) {
  auto o = std::make_shared<CheckCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_flag("--json", o->json, "Print the summary as JSON");
  cmd->add_option("--measurements", o->measurements,
                  "Labelled measurements: name what they leave undetermined");
  return [o] { return RunCheck(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareGraph(CLI::App* cmd) {
  auto o = std::make_shared<GraphCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("-o,--output", o->output, "Output file (default: stdout)");
  return [o] { return RunGraph(*o, std::cout, std::cerr); };
}

std::function<int()> DeclarePlan(CLI::App* cmd) {
  auto o = std::make_shared<PlanCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_flag("--image", o->image, "Plan for image (2D) measurements: seeds of 4 points");
  return [o] { return RunPlan(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareSolve(CLI::App* cmd) {
  auto o = std::make_shared<SolveCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--measurements", o->measurements, "Measurements (.json or .yaml)")->required();
  cmd->add_option("--guess", o->guess, "Starting poses (results format, e.g. a previous result)");
  cmd->add_option("-o,--output", o->output, "Result file (default: stdout)");
  cmd->add_option("--method", o->method,
                  "fusion (default), parametric (Lowe's, joints in a tree only) or components "
                  "(no constraints between components)")
      ->check(CLI::IsMember({"fusion", "parametric", "components"}));
  return [o] { return RunSolve(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareInterpret(CLI::App* cmd) {
  auto o = std::make_shared<InterpretCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--measurements", o->measurements, "Measurements (.json or .yaml)")->required();
  cmd->add_option("-o,--output", o->output, "Result file (default: stdout)");
  cmd->add_option("--tree", o->tree, "Write the explored tree (Graphviz dot)");
  cmd->add_option("--gate", o->gate, "Confidence of the chi-square gates (default 0.9999)")
      ->check(CLI::Range(0.5, 0.999999999));
  cmd->add_option("--max-nodes", o->max_nodes, "Node budget (default 20000)")
      ->check(CLI::Range(1L, 100000000L));
  return [o] { return RunInterpret(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareSimulate(CLI::App* cmd) {
  auto o = std::make_shared<SimulateCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_option("--noise", o->noise, "3D noise sigma, metres")->check(CLI::PositiveNumber);
  cmd->add_option("--pixel-noise", o->pixel_noise, "2D noise sigma, pixels")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--camera", o->camera,
                  "Camera file (cfuse's, OpenCV's, ViSP's or a ROS camera_info): 2D "
                  "measurements instead of 3D");
  cmd->add_option("--clutter", o->clutter, "Clutter points per real point")
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--occlusion", o->occlusion, "Fraction of model points not measured")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_flag("--labels", o->labels, "Keep labels (and order) on the real measurements");
  cmd->add_flag("--sample-joints", o->sample_joints,
                "Joint variables uniform inside their limits (articulated models)");
  cmd->add_option("-o,--output", o->output, "Measurement file to write")->required();
  cmd->add_option("--truth", o->truth, "Truth file to write")->required();
  return [o] { return RunSimulate(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareImport(CLI::App* cmd) {
  auto o = std::make_shared<ImportCommandOptions>();
  cmd->add_option("URDF", o->model, "Robot description (.urdf)")->required();
  cmd->add_option("-o,--output", o->output, "Model file to write (default: stdout)");
  return [o] { return RunImport(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareFk(CLI::App* cmd) {
  auto o = std::make_shared<FkCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--joints", o->joints,
                  "Joint values {\"name\": value} in rad or m (default: all 0)");
  cmd->add_option("-o,--output", o->output, "Pose file to write (default: stdout)");
  return [o] { return RunFk(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareSegments(CLI::App* cmd) {
  auto o = std::make_shared<SegmentsCommandOptions>();
  cmd->add_option("IMAGE", o->image, "Image (PNG, JPEG, ...; 8-bit grey or colour)")->required();
  cmd->add_option("--roi", o->roi, "Only the region x,y,w,h (pixels)");
  cmd->add_option("--detector", o->detector, "lowe (default), canny or lsd");
  cmd->add_option("-o,--output", o->output, "Segments file (default: stdout)");
  cmd->add_option("--overlay", o->overlay, "PNG of the segments on the image");
  return [o] { return RunSegments(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareProject(CLI::App* cmd) {
  auto o = std::make_shared<ProjectCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--camera", o->camera, "Camera file")->required();
  cmd->add_option("--pose", o->pose, "Poses (results format, or ViSP's .pos)")->required();
  cmd->add_option("-o,--output", o->output, "Edges file (default: stdout)");
  cmd->add_option("--overlay", o->overlay, "PNG of the edges drawn on --image");
  cmd->add_option("--image", o->image,
                  "The image to draw the edges on (its size for a camera without one)");
  return [o] { return RunProject(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareRender(CLI::App* cmd) {
  auto o = std::make_shared<RenderCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--camera", o->camera, "Camera file (no distortion)")->required();
  cmd->add_option("--pose", o->pose, "Poses (results format, or ViSP's .pos)");
  cmd->add_option("--sequence", o->sequence,
                  "A tracking sequence instead: steady, fast, occluded, clutter, jump or hand");
  cmd->add_option("--frames", o->frames, "Frames of the sequence")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("-o,--output", o->output, "PNG image to write (with --sequence: a new directory)")
      ->required();
  cmd->add_option("--truth", o->truth, "Visible edges file to write");
  cmd->add_option("--seed", o->seed, "Random seed of the clutter and noise");
  cmd->add_option("--noise", o->noise, "Noise sigma, grey levels")->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--blur", o->blur, "Blur sigma, pixels")->check(CLI::Range(0.0, 20.0));
  cmd->add_option("--clutter-lines", o->clutter_lines, "Background lines")
      ->check(CLI::Range(0, 10000));
  cmd->add_option("--clutter-blobs", o->clutter_blobs, "Background blobs")
      ->check(CLI::Range(0, 10000));
  cmd->add_option("--style", o->style,
                  "plain (default): flat grey faces over dark clutter; realistic: photographs "
                  "printed on the faces and behind them, a light with its highlight and a soft "
                  "shadow, motion blur (sequences), read and shot noise")
      ->capture_default_str();
  cmd->add_option(
      "--photographs", o->photographs,
      "With --style realistic: photographs (image files or directories) for the faces and the "
      "background; default: Debian's visp-images-data photographs if installed, else "
      "procedural cards");
  return [o] { return RunRender(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareTrack(CLI::App* cmd) {
  auto o = std::make_shared<TrackCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--camera", o->camera, "Camera file (without a size: the first frame's)")
      ->required();
  cmd->add_option("--images", o->images,
                  "The frames: a glob ('frames/*.png'), a directory or a video file")
      ->required();
  cmd->add_option("--init", o->init,
                  "Poses at the first frame (results format, or ViSP's .pos); without it the "
                  "object is detected");
  cmd->add_option("-o,--output", o->output, "Track file, CSV (default: stdout)");
  cmd->add_option("--overlay", o->overlay, "Directory for overlay frames (PNG)");
  cmd->add_option("--max-branches", o->max_branches, "Match sets tried per search range")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  auto* depth = cmd->add_option("--depth", o->depth,
                                "A range sensor's frames, one a frame: a glob or a directory of "
                                "raw depth files (.bin) or 16-bit images");
  auto* depth_camera = cmd->add_option("--depth-camera", o->depth_camera,
                                       "With --depth: the depth camera (any camera file)");
  depth->needs(depth_camera);
  depth_camera->needs(depth);
  cmd->add_option("--depth-pose", o->depth_pose,
                  "With --depth: ViSP's depth_M_color, the grey camera's pose in the depth "
                  "camera's frame (a 4x4 matrix file; default: the same camera)")
      ->needs(depth);
  cmd->add_option("--depth-scale", o->depth_scale, "With --depth: metres a depth unit")
      ->needs(depth)
      ->capture_default_str();
  cmd->add_option("--depth-distortion", o->depth_distortion,
                  "With --depth: RealSense's deprojection coefficients k1,k2,p1,p2,k3")
      ->delimiter(',')
      ->needs(depth);
  return [o] {
    o->progress = isatty(fileno(stderr)) != 0;
    return RunTrack(*o, std::cout, std::cerr);
  };
}

std::function<int()> DeclareDetect(CLI::App* cmd) {
  auto o = std::make_shared<DetectCommandOptions>();
  cmd->add_option("MODEL", o->model, "Model file (.yaml, .urdf or .cao)")->required();
  cmd->add_option("--camera", o->camera, "Camera file (without a size: the image's)")->required();
  cmd->add_option("--image", o->image, "The image to find the model in")->required();
  cmd->add_option("-o,--output", o->output, "Result file, JSON (default: stdout)");
  cmd->add_option("--overlay", o->overlay, "PNG of the model drawn where it was found");
  cmd->add_option("--max-results", o->max_results, "Objects reported at most")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  return [o] { return RunDetect(*o, std::cout, std::cerr); };
}

std::function<int()> DeclareDemo(CLI::App* cmd) {
  auto o = std::make_shared<DemoCommandOptions>();
  cmd->add_option("--picture", o->picture, "PNG picture to write")->capture_default_str();
  cmd->add_option("--track-overlay", o->track_overlay,
                  "Directory for the tracking part's overlay frames ('' for none)")
      ->capture_default_str();
  return [o] { return RunDemo(*o, std::cout, std::cerr); };
}

}  // namespace

const std::vector<Subcommand>& Subcommands() {
  static const std::vector<Subcommand> table = {
      {"check", "Validate a model and summarise it, with its DOF", DeclareCheck},
      {"graph", "Write the constraint graph in Graphviz dot", DeclareGraph},
      {"plan", "Print the fusion order (Hel-Or & Werman §6-7): constraints fused, points matched",
       DeclarePlan},
      {"solve", "Estimate poses from labelled measurements", DeclareSolve},
      {"interpret", "Match unlabelled measurements to the model and estimate (interpretation tree)",
       DeclareInterpret},
      {"simulate", "Synthetic measurements of a random configuration", DeclareSimulate},
      {"import", "Write a robot's URDF as a model file of the DSL", DeclareImport},
      {"fk", "Forward kinematics: every component's pose for joint values", DeclareFk},
      {"segments", "Detect straight line segments in an image", DeclareSegments},
      {"project", "The model's visible edges at a pose, in a camera's image", DeclareProject},
      {"render", "A synthetic image of the model at a pose, with clutter, and its true edges",
       DeclareRender},
      {"track", "Track the model through an image sequence (Lowe 1992 on constraint fusion)",
       DeclareTrack},
      {"detect", "Find the model in one image with no pose given (junctions, P3P, verification)",
       DeclareDetect},
      {"demo",
       "The built-in desk lamp simulated with clutter and occlusion, then interpreted; the hinged "
       "box tracked through a rendered sequence",
       DeclareDemo},
  };
  return table;
}

}  // namespace cfuse::cli
