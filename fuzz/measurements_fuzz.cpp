// Fuzz target: measurement files (3D points, image points, their camera). Besides the contract
// of every parser, the JSON fast path (dsl/src/measurement_json.h) must agree with the YAML
// reader: a trailing YAML comment hides the text from the fast path without moving anything, so
// both readings must accept alike and give the same measurements.
#include "cfuse/dsl/measurement_reader.h"
#include "fuzz/fuzz_util.h"
#include "measurement_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  const std::string text(fuzz::AsText(data, size));
  MeasurementSet direct, by_yaml;
  const bool accepted =
      fuzz::AcceptedOrRefused([&] { direct = ReadMeasurementsFromString(text, "fuzz.json"); });
  // Only texts the fast path takes are compared: the others go to the YAML reader anyway.
  const auto read_camera = [](std::string_view) { return Camera(); };
  const bool fast = [&] {
    try {
      return ReadPlainJsonMeasurements(text, "fuzz.json", read_camera).has_value();
    } catch (const InputError&) {
      return false;
    }
  }();
  if (!fast) return 0;
  std::string yaml_refusal;
  const bool accepted_by_yaml = fuzz::AcceptedOrRefused([&] {
    try {
      by_yaml = ReadMeasurementsFromString(text + "\n#", "fuzz.json");
    } catch (const InputError& e) {
      yaml_refusal = e.message();
      throw;
    }
  });
  // JSON that YAML 1.2 cannot parse (an implicit key spanning lines, or longer than 1024
  // characters): the fast path reads it, as any JSON parser must. Not a disagreement on what
  // the measurements are.
  if (accepted && !accepted_by_yaml && yaml_refusal.starts_with("YAML syntax error")) return 0;
  if (accepted != accepted_by_yaml) {
    fuzz::Finding("the JSON fast path and the YAML reader disagree on acceptance", text);
  }
  if (accepted && !SameMeasurements(direct, by_yaml)) {
    fuzz::Finding("the JSON fast path and the YAML reader read different measurements", text);
  }
  return 0;
}
