// The constraint-fusion estimator (issue 3): the lamp fused from 23 labelled 3D points and all
// its constraints, and how the cost grows along a chain of points.
#include <benchmark/benchmark.h>

#include <random>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/fusion_order.h"
#include "cfuse/kernel/measurements/point3.h"
#include "cfuse/kernel/sparse_solver.h"

namespace cfuse {
namespace {

// `measured`, if given, gets each point at its measurement: the start a solve would take.
std::vector<Factor> MeasuredModel(const ConstraintGraph& g, unsigned seed,
                                  Values* measured = nullptr) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 0.002);
  const Rigid3d pose(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 1, 0).normalized())),
      Eigen::Vector3d(0.1, -0.2, 1.5));
  std::vector<Factor> factors;
  if (measured) *measured = g.nominal;
  for (const Component& c : g.components) {
    const Eigen::Vector3d z =
        pose * g.nominal.points[g.blocks[c.block].index] + Eigen::Vector3d(n(rng), n(rng), n(rng));
    if (measured) measured->points[g.blocks[c.block].index] = z;
    factors.push_back({std::make_shared<Point3Residual>(z),
                       {c.block},
                       4e-6 * Eigen::Matrix3d::Identity(),
                       c.name});
  }
  for (const Constraint& c : g.constraints) factors.push_back({c.residual, c.blocks, {}, c.name});
  return factors;
}

// The measurement factors, then the constraints in the order of cfuse/kernel/fusion_order.h.
std::vector<Factor> InFusionOrder(const ConstraintGraph& g, std::vector<Factor> factors) {
  std::vector<Factor> ordered;
  for (int i : GroupGrowthOrder(factors, static_cast<int>(g.blocks.size()))) {
    ordered.push_back(factors[i]);
  }
  return ordered;
}

// The paper's constraint fusion: each measurement and each constraint fused once, in turn,
// with local iterations.
void BM_FuseLamp(benchmark::State& state) {
  const ConstraintGraph g = LoadModel(std::string(CFUSE_SOURCE_DIR) + "/examples/lamp.yaml");
  const std::vector<Factor> factors = InFusionOrder(g, MeasuredModel(g, 1));
  const GaussianState prior = MakePrior(g.blocks, g.nominal, PriorScale{});
  GaussianState s = prior;
  for (auto _ : state) {
    s = prior;
    for (const Factor& f : factors) Fuse(f, &s);
    benchmark::DoNotOptimize(s.covariance.data());
  }
  state.counters["max_residual_m"] = MaxConstraintResidual(factors, s.blocks, s.mean);
}
BENCHMARK(BM_FuseLamp)->Unit(benchmark::kMicrosecond);

// What `cfuse solve` runs: that pass, then Gauss-Newton passes (FuseSequence) until every
// constraint holds to 1e-8 of the model's extent.
void BM_SolveLamp(benchmark::State& state) {
  const ConstraintGraph g = LoadModel(std::string(CFUSE_SOURCE_DIR) + "/examples/lamp.yaml");
  const std::vector<Factor> factors = InFusionOrder(g, MeasuredModel(g, 1));
  const GaussianState prior = MakePrior(g.blocks, g.nominal, PriorScale{});
  SequenceOptions options;
  options.constraint_tolerance = 1e-8 * 0.5;  // the lamp's extent is about 0.5 m
  GaussianState s = prior;
  int passes = 0;
  for (auto _ : state) {
    s = prior;
    passes = FuseSequence(factors, &s, options).passes;
    benchmark::DoNotOptimize(s.covariance.data());
  }
  state.counters["passes"] = passes;
  state.counters["max_residual_m"] = MaxConstraintResidual(factors, s.blocks, s.mean);
}
BENCHMARK(BM_SolveLamp)->Unit(benchmark::kMicrosecond);

// A chain of N points, each measured, consecutive ones at fixed distances.
ConstraintGraph Chain(int n) {
  ModelBuilder b("chain", "bench");
  for (int i = 0; i < n; ++i) {
    b.AddPointComponent("p" + std::to_string(i), Eigen::Vector3d(0.1 * i, 0.02 * (i % 3), 0), {});
  }
  for (int i = 0; i + 1 < n; ++i) {
    std::string why;
    const auto P = [&](int k) { return MakePointRef(b.graph().components[k].block); };
    const ExprPtr d = MakeCall(Function::kDistance, {P(i), P(i + 1)}, &why);
    const double nominal = (b.graph().nominal.points[i] - b.graph().nominal.points[i + 1]).norm();
    b.AddConstraint(
        "d" + std::to_string(i), ConstraintKind::kDistanceEquality, "distance ==",
        EqualityResidual::Create(d, MakeConstant(nominal, Quantity::Length()), b.Context()), {});
  }
  return std::move(b).Build();
}

void BM_FuseChain(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const ConstraintGraph g = Chain(n);
  const std::vector<Factor> factors = InFusionOrder(g, MeasuredModel(g, 2));
  const GaussianState prior = MakePrior(g.blocks, g.nominal, PriorScale{});
  for (auto _ : state) {
    GaussianState s = prior;
    FuseSequence(factors, &s);
    benchmark::DoNotOptimize(s.covariance.data());
  }
  state.SetComplexityN(n);
}
BENCHMARK(BM_FuseChain)
    ->Arg(10)
    ->Arg(30)
    ->Arg(100)
    ->Arg(300)
    ->Unit(benchmark::kMillisecond)
    ->Complexity();

// Times SolveSparse on one problem, from `start`, and reports its iterations and the
// constraints' largest residual.
void RunSparse(benchmark::State& state, const ConstraintGraph& g,
               const std::vector<Factor>& factors, const Values& start,
               const std::vector<std::pair<int, int>>& pairs) {
  const Eigen::VectorXd variance = PriorVariance(g.blocks, PriorScale{});
  SparseEstimate estimate;
  SparseSummary summary;
  for (auto _ : state) {
    summary = SolveSparse(factors, g.blocks, g.nominal, variance, pairs, &estimate, {}, &start);
    benchmark::DoNotOptimize(estimate.mean.points.data());
  }
  if (!summary.converged) state.SkipWithError("not converged");
  state.counters["iterations"] = summary.iterations;
  state.counters["factor_entries"] = static_cast<double>(summary.factor_nonzeros);
  state.counters["max_residual_m"] = summary.max_constraint_residual;
}

// The same chain solved at once by the sparse solver (sparse_solver.h), with every point's
// covariance and that of each pair of neighbours, from each point at its measurement (where
// `cfuse solve` would start: the filter's first pass has no start but the prior's mean).
void BM_SolveSparseChain(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const ConstraintGraph g = Chain(n);
  Values start;
  const std::vector<Factor> factors = MeasuredModel(g, 2, &start);
  std::vector<std::pair<int, int>> neighbours;
  for (int i = 0; i + 1 < n; ++i) neighbours.emplace_back(i, i + 1);
  RunSparse(state, g, factors, start, neighbours);
  state.SetComplexityN(n);
}
BENCHMARK(BM_SolveSparseChain)
    ->Arg(10)
    ->Arg(30)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Arg(3000)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond)
    ->Complexity();

// The lamp (BM_SolveLamp's problem) solved at once by the sparse solver, with every block's
// covariance, from each point at its measurement.
void BM_SolveSparseLamp(benchmark::State& state) {
  const ConstraintGraph g = LoadModel(std::string(CFUSE_SOURCE_DIR) + "/examples/lamp.yaml");
  Values start;
  const std::vector<Factor> factors = MeasuredModel(g, 1, &start);
  RunSparse(state, g, factors, start, {});
}
BENCHMARK(BM_SolveSparseLamp)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace cfuse
