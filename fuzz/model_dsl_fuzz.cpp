// Fuzz target: a model file of the DSL (YAML, constraint expressions, includes), then what
// `cfuse check` and `cfuse plan` do with an accepted model.
#include "cfuse/constraints/dof.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/cao.h"
#include "cfuse/importers/urdf.h"
#include "cfuse/interp/schedule.h"
#include "fuzz/fuzz_util.h"

namespace {

cfuse::LoadOptions Options() {
  cfuse::LoadOptions options;
  options.include_handlers[".urdf"] = [](const std::string& path,
                                         const cfuse::SourceLocation& where) {
    return cfuse::ImportUrdf(path, where);
  };
  options.include_handlers[".cao"] = [](const std::string& path,
                                        const cfuse::SourceLocation& where) {
    return cfuse::ImportCao(path, where);
  };
  return options;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  static const LoadOptions options = Options();
  // Relative includes resolve against the examples, so that `include: parts/planar-link.yaml`
  // in a seed reaches a real file.
  static const std::string base = CFUSE_FUZZ_SOURCE_DIR "/examples";
  ConstraintGraph graph;
  const bool accepted = fuzz::AcceptedOrRefused([&] {
    graph = LoadModelFromString(fuzz::AsText(data, size), "fuzz.yaml", base, options);
  });
  // The analyses of an accepted model must not fail on it: they are what `check` runs next.
  // Small models only, to keep executions fast (their cost is benchmarked elsewhere).
  if (accepted && graph.components.size() <= 16 && graph.tangent_dim() <= 200) {
    fuzz::AcceptedOrRefused([&] {
      (void)AnalyzeDof(graph, graph.nominal);
      (void)PlanFusion(graph, /*image_data=*/false);
      (void)PlanFusion(graph, /*image_data=*/true);
    });
  }
  return 0;
}
