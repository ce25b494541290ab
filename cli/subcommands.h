// The table of `cfuse`'s subcommands. Adding a command is its Run*() function, one Declare*()
// function in subcommands.cpp for its options, and one row of the table.
#pragma once

#include <functional>
#include <vector>

namespace CLI {
class App;
}

namespace cfuse::cli {

struct Subcommand {
  const char* name;
  const char* summary;
  // Declares the command's options on its parser; returns what runs the command once the
  // command line is parsed, with its exit status (0 right, 1 no answer, 2 bad input).
  std::function<std::function<int()>(CLI::App*)> declare;
};

const std::vector<Subcommand>& Subcommands();

}  // namespace cfuse::cli
