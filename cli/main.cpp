// cfuse: a table of subcommands; every one is a Run*() function in commands.h.
#include <CLI/CLI.hpp>
#include <iostream>

#include "cli/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"cfuse: pose estimation and interpretation of articulated and constrained objects"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "cfuse 0.1.0");

  cfuse::cli::CheckOptions check;
  CLI::App* check_cmd =
      app.add_subcommand("check", "Validate a model and summarise it, with its DOF");
  check_cmd->add_option("MODEL", check.model, "Model file (.yaml or .urdf)")->required();
  check_cmd->add_flag("--json", check.json, "Print the summary as JSON");

  cfuse::cli::GraphOptions graph;
  CLI::App* graph_cmd = app.add_subcommand("graph", "Write the constraint graph in Graphviz dot");
  graph_cmd->add_option("MODEL", graph.model, "Model file (.yaml or .urdf)")->required();
  graph_cmd->add_option("-o,--output", graph.output, "Output file (default: stdout)");

  cfuse::cli::PlanCommandOptions plan;
  CLI::App* plan_cmd = app.add_subcommand(
      "plan", "Print the fusion order (Hel-Or & Werman §6-7): constraints fused, points matched");
  plan_cmd->add_option("MODEL", plan.model, "Model file (.yaml or .urdf)")->required();
  plan_cmd->add_flag("--image", plan.image, "Plan for image (2D) measurements: seeds of 4 points");

  cfuse::cli::SolveCommandOptions solve;
  CLI::App* solve_cmd = app.add_subcommand("solve", "Estimate poses from labelled measurements");
  solve_cmd->add_option("MODEL", solve.model, "Model file (.yaml or .urdf)")->required();
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
  interp_cmd->add_option("MODEL", interp.model, "Model file (.yaml or .urdf)")->required();
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
  sim_cmd->add_option("MODEL", sim.model, "Model file (.yaml or .urdf)")->required();
  sim_cmd->add_option("--seed", sim.seed, "Random seed");
  sim_cmd->add_option("--noise", sim.noise, "3D noise sigma, metres")->check(CLI::PositiveNumber);
  sim_cmd->add_option("--pixel-noise", sim.pixel_noise, "2D noise sigma, pixels")
      ->check(CLI::PositiveNumber);
  sim_cmd->add_option("--camera", sim.camera, "Camera file: 2D measurements instead of 3D");
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
  fk_cmd->add_option("MODEL", fk.model, "Model file (.yaml or .urdf)")->required();
  fk_cmd->add_option("--joints", fk.joints,
                     "Joint values {\"name\": value} in rad or m (default: all 0)");
  fk_cmd->add_option("-o,--output", fk.output, "Pose file to write (default: stdout)");

  CLI::App* demo_cmd = app.add_subcommand(
      "demo", "The built-in desk lamp: simulated with clutter and occlusion, then interpreted");
  cfuse::cli::DemoOptions demo;
  demo_cmd->add_option("--picture", demo.picture, "PNG picture to write")->capture_default_str();

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
  if (*demo_cmd) return cfuse::cli::RunDemo(demo, std::cout, std::cerr);
  return 2;
}
