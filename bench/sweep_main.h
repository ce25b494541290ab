// main() of the sweep programs (interpret_sweep, robot_sweep, segments_bench, track_sweep):
// bad input — a model file's InputError, a bad option value, a peer's model it cannot read — is
// one line on stderr and exit status 2.
#pragma once

#include <fmt/format.h>

#include <stdexcept>

#include "kernel/measurements/camera.h"

namespace cfuse::bench {

// The sweeps' camera: a 640 x 480 pinhole with an 800 px focal length, centred.
inline Camera SweepCamera() {
  Camera c;
  c.fx = c.fy = 800;
  c.cx = 320;
  c.cy = 240;
  c.width = 640;
  c.height = 480;
  return c;
}

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
