// The cost of the constraint graph's building blocks: loading a model, evaluating residuals
// with and without their autodiff Jacobians, the rank-based DOF analysis.
#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "cfuse/constraints/dof.h"
#include "cfuse/constraints/evaluate.h"
#include "cfuse/dsl/model_loader.h"

namespace cfuse {
namespace {

const std::string kLamp = std::string(CFUSE_SOURCE_DIR) + "/examples/lamp.yaml";
const std::string kBox = std::string(CFUSE_SOURCE_DIR) + "/examples/hinged-box.yaml";

void BM_LoadLampModel(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(LoadModel(kLamp));
}
BENCHMARK(BM_LoadLampModel)->Unit(benchmark::kMicrosecond);

// All 56 lamp constraints (58 equations x 69 state variables).
void BM_LampResiduals(benchmark::State& state) {
  const ConstraintGraph g = LoadModel(kLamp);
  Eigen::VectorXd r;
  for (auto _ : state) {
    EvaluateConstraints(g, g.nominal, &r, nullptr);
    benchmark::DoNotOptimize(r.data());
  }
}
BENCHMARK(BM_LampResiduals)->Unit(benchmark::kMicrosecond);

void BM_LampResidualsAndJacobian(benchmark::State& state) {
  const ConstraintGraph g = LoadModel(kLamp);
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  for (auto _ : state) {
    EvaluateConstraints(g, g.nominal, &r, &J);
    benchmark::DoNotOptimize(J.data());
  }
}
BENCHMARK(BM_LampResidualsAndJacobian)->Unit(benchmark::kMicrosecond);

void BM_LampDofAnalysis(benchmark::State& state) {
  const ConstraintGraph g = LoadModel(kLamp);
  for (auto _ : state) benchmark::DoNotOptimize(AnalyzeDof(g, g.nominal));
}
BENCHMARK(BM_LampDofAnalysis)->Unit(benchmark::kMillisecond);

// A chain of n single points held by n - 1 distances: loading scales linearly.
void BM_LoadPointChain(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  std::string text = "points:\n";
  for (int i = 0; i < n; ++i)
    text += fmt::format("  p{}: [{}, {}, 0]\n", i, 0.01 * i, 0.01 * (i % 3));
  text += "constraints:\n";
  for (int i = 0; i + 1 < n; ++i)
    text += fmt::format("  - distance(p{}, p{}) == nominal\n", i, i + 1);
  for (auto _ : state) benchmark::DoNotOptimize(LoadModelFromString(text, "chain.yaml", "."));
  state.SetComplexityN(n);
}
BENCHMARK(BM_LoadPointChain)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond)->Complexity();

// One revolute joint (5 x 12 Jacobian): the typical articulated-model row block.
void BM_RevoluteJointJacobian(benchmark::State& state) {
  const ConstraintGraph g = LoadModel(kBox);
  const Constraint& c = g.constraints[g.FindConstraint("hinge")];
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  for (auto _ : state) {
    EvaluateResidual(*c.residual, g.blocks, c.blocks, g.nominal, &r, &J);
    benchmark::DoNotOptimize(J.data());
  }
}
BENCHMARK(BM_RevoluteJointJacobian)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace cfuse

BENCHMARK_MAIN();
