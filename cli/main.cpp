// cfuse: a table of subcommands; every one is a Run*() function in commands.h.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "cli/commands.h"
#include "cli/image_commands.h"
#include "cli/track_command.h"

int main(int argc, char** argv) {
  CLI::App app{"cfuse: pose estimation and interpretation of articulated and constrained objects"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "cfuse 0.1.0");

  cfuse::cli::CheckOptions check;
  CLI::App* check_cmd =
      app.add_subcommand("check", "Validate a model and summarise it, with its DOF");
  check_cmd->add_option("MODEL", check.model, "Model file (.yaml, .urdf or .cao)")->required();
  check_cmd->add_flag("--json", check.json, "Print the summary as JSON");
  check_cmd->add_option("--measurements", check.measurements,
                        "Labelled measurements: name what they leave undetermined");

  cfuse::cli::GraphOptions graph;
  CLI::App* graph_cmd = app.add_subcommand("graph", "Write the constraint graph in Graphviz dot");
  graph_cmd->add_option("MODEL", graph.model, "Model file (.yaml, .urdf or .cao)")->required();
  graph_cmd->add_option("-o,--output", graph.output, "Output file (default: stdout)");

  cfuse::cli::PlanCommandOptions plan;
  CLI::App* plan_cmd = app.add_subcommand(
      "plan", "Print the fusion order (Hel-Or & Werman §6-7): constraints fused, points matched");
  plan_cmd->add_option("MODEL", plan.model, "Model file (.yaml, .urdf or .cao)")->required();
  plan_cmd->add_flag("--image", plan.image, "Plan for image (2D) measurements: seeds of 4 points");

  cfuse::cli::SolveCommandOptions solve;
  CLI::App* solve_cmd = app.add_subcommand("solve", "Estimate poses from labelled measurements");
  solve_cmd->add_option("MODEL", solve.model, "Model file (.yaml, .urdf or .cao)")->required();
  solve_cmd->add_option("--measurements", solve.measurements, "Measurements (.json or .yaml)")
      ->required();
  solve_cmd->add_option("--guess", solve.guess,
                        "Starting poses (results format, e.g. a previous result)");
  solve_cmd->add_option("-o,--output", solve.output, "Result file (default: stdout)");
  solve_cmd
      ->add_option("--method", solve.method,
                   "fusion (default), parametric (Lowe's, joints in a tree only) or components "
                   "(no constraints between components)")
      ->check(CLI::IsMember({"fusion", "parametric", "components"}));

  cfuse::cli::InterpretCommandOptions interp;
  CLI::App* interp_cmd = app.add_subcommand(
      "interpret", "Match unlabelled measurements to the model and estimate (interpretation tree)");
  interp_cmd->add_option("MODEL", interp.model, "Model file (.yaml, .urdf or .cao)")->required();
  interp_cmd->add_option("--measurements", interp.measurements, "Measurements (.json or .yaml)")
      ->required();
  interp_cmd->add_option("-o,--output", interp.output, "Result file (default: stdout)");
  interp_cmd->add_option("--tree", interp.tree, "Write the explored tree (Graphviz dot)");
  interp_cmd
      ->add_option("--gate", interp.gate, "Confidence of the chi-square gates (default 0.9999)")
      ->check(CLI::Range(0.5, 0.999999999));
  interp_cmd->add_option("--max-nodes", interp.max_nodes, "Node budget (default 20000)")
      ->check(CLI::Range(1L, 100000000L));

  cfuse::cli::SimulateCommandOptions sim;
  CLI::App* sim_cmd =
      app.add_subcommand("simulate", "Synthetic measurements of a random configuration");
  sim_cmd->add_option("MODEL", sim.model, "Model file (.yaml, .urdf or .cao)")->required();
  sim_cmd->add_option("--seed", sim.seed, "Random seed");
  sim_cmd->add_option("--noise", sim.noise, "3D noise sigma, metres")->check(CLI::PositiveNumber);
  sim_cmd->add_option("--pixel-noise", sim.pixel_noise, "2D noise sigma, pixels")
      ->check(CLI::PositiveNumber);
  sim_cmd->add_option("--camera", sim.camera,
                      "Camera file (cfuse's, OpenCV's, ViSP's or a ROS camera_info): 2D "
                      "measurements instead of 3D");
  sim_cmd->add_option("--clutter", sim.clutter, "Clutter points per real point")
      ->check(CLI::Range(0.0, 100.0));
  sim_cmd->add_option("--occlusion", sim.occlusion, "Fraction of model points not measured")
      ->check(CLI::Range(0.0, 1.0));
  sim_cmd->add_flag("--labels", sim.labels, "Keep labels (and order) on the real measurements");
  sim_cmd->add_flag("--sample-joints", sim.sample_joints,
                    "Joint variables uniform inside their limits (articulated models)");
  sim_cmd->add_option("-o,--output", sim.output, "Measurement file to write")->required();
  sim_cmd->add_option("--truth", sim.truth, "Truth file to write")->required();

  CLI::App* import_cmd =
      app.add_subcommand("import", "Write a robot's URDF as a model file of the DSL");
  cfuse::cli::ImportOptions import;
  import_cmd->add_option("URDF", import.model, "Robot description (.urdf)")->required();
  import_cmd->add_option("-o,--output", import.output, "Model file to write (default: stdout)");

  CLI::App* fk_cmd =
      app.add_subcommand("fk", "Forward kinematics: every component's pose for joint values");
  cfuse::cli::FkOptions fk;
  fk_cmd->add_option("MODEL", fk.model, "Model file (.yaml, .urdf or .cao)")->required();
  fk_cmd->add_option("--joints", fk.joints,
                     "Joint values {\"name\": value} in rad or m (default: all 0)");
  fk_cmd->add_option("-o,--output", fk.output, "Pose file to write (default: stdout)");

  CLI::App* segments_cmd =
      app.add_subcommand("segments", "Detect straight line segments in an image");
  cfuse::cli::SegmentsCommandOptions segments;
  segments_cmd->add_option("IMAGE", segments.image, "Image (PNG, JPEG, ...; 8-bit grey or colour)")
      ->required();
  segments_cmd->add_option("--roi", segments.roi, "Only the region x,y,w,h (pixels)");
  segments_cmd->add_option("--detector", segments.detector, "lowe (default), canny or lsd");
  segments_cmd->add_option("-o,--output", segments.output, "Segments file (default: stdout)");
  segments_cmd->add_option("--overlay", segments.overlay, "PNG of the segments on the image");

  CLI::App* project_cmd =
      app.add_subcommand("project", "The model's visible edges at a pose, in a camera's image");
  cfuse::cli::ProjectCommandOptions project;
  project_cmd->add_option("MODEL", project.model, "Model file (.yaml, .urdf or .cao)")->required();
  project_cmd->add_option("--camera", project.camera, "Camera file")->required();
  project_cmd->add_option("--pose", project.pose, "Poses (results format, or ViSP's .pos)")
      ->required();
  project_cmd->add_option("-o,--output", project.output, "Edges file (default: stdout)");
  project_cmd->add_option("--overlay", project.overlay, "PNG of the edges drawn on --image");
  project_cmd->add_option("--image", project.image,
                          "The image to draw the edges on (its size for a camera without one)");

  CLI::App* render_cmd = app.add_subcommand(
      "render", "A synthetic image of the model at a pose, with clutter, and its true edges");
  cfuse::cli::RenderCommandOptions render;
  render_cmd->add_option("MODEL", render.model, "Model file (.yaml, .urdf or .cao)")->required();
  render_cmd->add_option("--camera", render.camera, "Camera file (no distortion)")->required();
  render_cmd->add_option("--pose", render.pose, "Poses (results format, or ViSP's .pos)");
  render_cmd->add_option(
      "--sequence", render.sequence,
      "A tracking sequence instead: steady, fast, occluded, clutter, jump or hand");
  render_cmd->add_option("--frames", render.frames, "Frames of the sequence")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  render_cmd
      ->add_option("-o,--output", render.output,
                   "PNG image to write (with --sequence: a new directory)")
      ->required();
  render_cmd->add_option("--truth", render.truth, "Visible edges file to write");
  render_cmd->add_option("--seed", render.seed, "Random seed of the clutter and noise");
  render_cmd->add_option("--noise", render.noise, "Noise sigma, grey levels")
      ->check(CLI::Range(0.0, 100.0));
  render_cmd->add_option("--blur", render.blur, "Blur sigma, pixels")->check(CLI::Range(0.0, 20.0));
  render_cmd->add_option("--clutter-lines", render.clutter_lines, "Background lines")
      ->check(CLI::Range(0, 10000));
  render_cmd->add_option("--clutter-blobs", render.clutter_blobs, "Background blobs")
      ->check(CLI::Range(0, 10000));
  render_cmd
      ->add_option("--style", render.style,
                   "plain (default): flat grey faces over dark clutter; realistic: photographs "
                   "printed on the faces and behind them, a light with its highlight and a soft "
                   "shadow, motion blur (sequences), read and shot noise")
      ->capture_default_str();
  render_cmd->add_option(
      "--photographs", render.photographs,
      "With --style realistic: photographs (image files or directories) for the faces and the "
      "background; default: Debian's visp-images-data photographs if installed, else "
      "procedural cards");

  CLI::App* track_cmd = app.add_subcommand(
      "track", "Track the model through an image sequence (Lowe 1992 on constraint fusion)");
  cfuse::cli::TrackCommandOptions track;
  track_cmd->add_option("MODEL", track.model, "Model file (.yaml, .urdf or .cao)")->required();
  track_cmd->add_option("--camera", track.camera, "Camera file (without a size: the first frame's)")
      ->required();
  track_cmd
      ->add_option("--images", track.images,
                   "The frames: a glob ('frames/*.png'), a directory or a video file")
      ->required();
  track_cmd
      ->add_option("--init", track.init,
                   "Poses at the first frame (results format, or ViSP's .pos)")
      ->required();
  track_cmd->add_option("-o,--output", track.output, "Track file, CSV (default: stdout)");
  track_cmd->add_option("--overlay", track.overlay, "Directory for overlay frames (PNG)");
  track_cmd->add_option("--max-branches", track.max_branches, "Match sets tried per search range")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();

  CLI::App* demo_cmd = app.add_subcommand(
      "demo",
      "The built-in desk lamp simulated with clutter and occlusion, then interpreted; the hinged "
      "box tracked through a rendered sequence");
  cfuse::cli::DemoOptions demo;
  demo_cmd->add_option("--picture", demo.picture, "PNG picture to write")->capture_default_str();
  demo_cmd
      ->add_option("--track-overlay", demo.track_overlay,
                   "Directory for the tracking part's overlay frames ('' for none)")
      ->capture_default_str();

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;  // command-line misuse is bad input
  }
  if (*check_cmd) return cfuse::cli::RunCheck(check, std::cout, std::cerr);
  if (*graph_cmd) return cfuse::cli::RunGraph(graph, std::cout, std::cerr);
  if (*plan_cmd) return cfuse::cli::RunPlan(plan, std::cout, std::cerr);
  if (*solve_cmd) return cfuse::cli::RunSolve(solve, std::cout, std::cerr);
  if (*interp_cmd) return cfuse::cli::RunInterpret(interp, std::cout, std::cerr);
  if (*sim_cmd) return cfuse::cli::RunSimulate(sim, std::cout, std::cerr);
  if (*import_cmd) return cfuse::cli::RunImport(import, std::cout, std::cerr);
  if (*fk_cmd) return cfuse::cli::RunFk(fk, std::cout, std::cerr);
  if (*segments_cmd) return cfuse::cli::RunSegments(segments, std::cout, std::cerr);
  if (*project_cmd) return cfuse::cli::RunProject(project, std::cout, std::cerr);
  if (*render_cmd) return cfuse::cli::RunRender(render, std::cout, std::cerr);
  if (*track_cmd) {
    track.progress = isatty(fileno(stderr)) != 0;
    return cfuse::cli::RunTrack(track, std::cout, std::cerr);
  }
  if (*demo_cmd) return cfuse::cli::RunDemo(demo, std::cout, std::cerr);
  return 2;
}
