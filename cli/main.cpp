// cfuse: the program, a table of subcommands (subcommands.h).
#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

#include "cli/subcommands.h"

int main(int argc, char** argv) {
  CLI::App app{"cfuse: pose estimation and interpretation of articulated and constrained objects"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "cfuse 0.1.0");
  std::vector<std::pair<CLI::App*, std::function<int()>>> commands;
  for (const cfuse::cli::Subcommand& s : cfuse::cli::Subcommands()) {
    CLI::App* cmd = app.add_subcommand(s.name, s.summary);
    commands.emplace_back(cmd, s.declare(cmd));
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;  // command-line misuse is bad input
  }
  for (const auto& [cmd, run] : commands) {
    if (*cmd) return run();
  }
  return 2;
}
