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
  check_cmd->add_option("MODEL", check.model, "Model file (.yaml)")->required();
  check_cmd->add_flag("--json", check.json, "Print the summary as JSON");

  cfuse::cli::GraphOptions graph;
  CLI::App* graph_cmd = app.add_subcommand("graph", "Write the constraint graph in Graphviz dot");
  graph_cmd->add_option("MODEL", graph.model, "Model file (.yaml)")->required();
  graph_cmd->add_option("-o,--output", graph.output, "Output file (default: stdout)");

  cfuse::cli::SolveCommandOptions solve;
  CLI::App* solve_cmd = app.add_subcommand("solve", "Estimate poses from labelled measurements");
  solve_cmd->add_option("MODEL", solve.model, "Model file (.yaml)")->required();
  solve_cmd->add_option("--measurements", solve.measurements, "Measurements (.json or .yaml)")
      ->required();
  solve_cmd->add_option("-o,--output", solve.output, "Result file (default: stdout)");

  CLI::App* demo_cmd = app.add_subcommand("demo", "A short built-in run on the desk lamp model");

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
  if (*solve_cmd) return cfuse::cli::RunSolve(solve, std::cout, std::cerr);
  if (*demo_cmd) return cfuse::cli::RunDemo(std::cout, std::cerr);
  return 2;
}
