// main() of the sweep programs (interpret_sweep, robot_sweep, segments_bench, track_sweep):
// bad input — a model file's InputError, a bad option value, a peer's model it cannot read — is
// one line on stderr and exit status 2.
#pragma once

#include <fmt/format.h>

#include <stdexcept>

namespace cfuse::bench {

inline int SweepMain(const char* name, int (*run)(int, char**), int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "{}: {}\n", name, e.what());
  } catch (const std::runtime_error& e) {  // InputError among them
    fmt::print(stderr, "{}: {}\n", name, e.what());
  }
  return 2;
}

}  // namespace cfuse::bench
