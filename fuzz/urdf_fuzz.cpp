// Fuzz target: URDF import (tinyxml, then urdfdom, then cfuse's checks), and the round trip
// `cfuse import` promises: the accepted robot, written as a model of the DSL, reads back with
// the same components, joints and constraints.
#include "cfuse/dsl/model_loader.h"
#include "cfuse/dsl/model_writer.h"
#include "cfuse/importers/urdf.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  ConstraintGraph graph;
  if (!fuzz::AcceptedOrRefused([&] {
        graph = ImportUrdfFromString(fuzz::AsText(data, size), "fuzz.urdf");
      })) {
    return 0;
  }
  std::string written;
  ConstraintGraph reread;
  try {
    written = WriteModel(graph);
    reread = LoadModelFromString(written, "imported.yaml", ".");
  } catch (const std::exception& e) {
    fuzz::Finding("an accepted URDF does not round-trip through the DSL", e.what());
  }
  if (reread.components.size() != graph.components.size() ||
      reread.joints.size() != graph.joints.size() ||
      reread.constraints.size() != graph.constraints.size()) {
    fuzz::Finding("the DSL written for a URDF reads back as another model", written);
  }
  return 0;
}
