// Helpers shared by the tests.
#pragma once

#include <catch2/catch.hpp>
#include <cstdlib>
#include <string>

#include "cfuse/kernel/error.h"
#include "cfuse/kernel/measurements/camera.h"

namespace cfuse::testing {

// The repository root (set by ctest; tests also run from it).
inline std::string SourceDir() {
  const char* dir = std::getenv("CFUSE_SOURCE_DIR");
  return dir ? dir : ".";
}

inline std::string SourcePath(const std::string& relative) { return SourceDir() + "/" + relative; }

// A 640 x 480 pinhole camera with an 800-pixel focal length (the benchmark's too).
inline Camera Pinhole() {
  Camera camera;
  camera.fx = camera.fy = 800;
  camera.cx = 320;
  camera.cy = 240;
  camera.width = 640;
  camera.height = 480;
  return camera;
}

// The InputError that `f` throws; a test failure when it throws none.
template <typename F>
InputError ErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e;
  }
  FAIL("accepted");
  return InputError(SourceLocation(), "");
}

// A malformed input and where and how it must be refused.
struct BadCase {
  const char* text;
  int line, column;
  const char* message;  // the start of the message
};

// Each case's text, read by `read(text, "bad.json")`, must throw an InputError at its place.
template <typename Reader>
void ExpectRefused(const BadCase* begin, const BadCase* end, Reader read) {
  for (const BadCase* c = begin; c != end; ++c) {
    INFO(c->text);
    try {
      read(c->text, "bad.json");
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().file == "bad.json");
      CHECK(e.where().line == c->line);
      CHECK(e.where().column == c->column);
      CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c->message));
    }
  }
}

}  // namespace cfuse::testing
