// Evaluating a residual and its Jacobian on block values: the Jacobian against central
// differences in the chart (values.h), at the values and moved by a tangent offset δ, for a
// residual of every block kind whose 16 tangent coordinates take three automatic-differentiation
// passes; the block states gathered; and the contract on slots and offsets.
#include "cfuse/kernel/evaluate.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

// Nonlinear in every coordinate of its slots: pose a, point p, slack λ, pose b.
class Mixed : public AutoDiffResidual<Mixed> {
 public:
  Mixed()
      : AutoDiffResidual(
            7, {BlockKind::kPose, BlockKind::kPoint, BlockKind::kSlack, BlockKind::kPose}) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> c = x[0].R * Vector3<T>(T(0.2), T(-0.1), T(0.3)) + x[0].t - x[1].t;
    const Vector3<T> d = x[3].R.transpose() * (x[1].t - x[3].t) * x[2].slack();
    for (int i = 0; i < 3; ++i) r[i] = c[i];
    r[3] = x[2].slack() * x[2].slack() + (x[3].R * Vector3<T>(T(1), T(2), T(0))).dot(x[0].t);
    for (int i = 0; i < 3; ++i) r[4 + i] = d[i];
  }
  std::string Describe(std::span<const std::string> names) const override {
    return "mixed(" + names[0] + ", ...)";
  }
};

// The slots' blocks among others, in another order than the slots, with tangent offsets to match.
struct Graph {
  std::vector<Block> blocks = {{BlockKind::kPoint, 0, 0, "p"},
                               {BlockKind::kPose, 1, 3, "b"},
                               {BlockKind::kSlack, 0, 9, "k.slack"},
                               {BlockKind::kPose, 0, 10, "a"},
                               {BlockKind::kPoint, 1, 16, "unused"}};
  std::vector<int> slots = {3, 0, 2, 1};
  Values values;
  Graph() {
    values.poses = {Rigid3d(Eigen::Quaterniond(0.3, -0.5, 0.7, 0.2).normalized(),
                            Eigen::Vector3d(0.1, -0.05, 1.8)),
                    Rigid3d(Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized(),
                            Eigen::Vector3d(-0.4, 0.3, 0.6))};
    values.points = {Eigen::Vector3d(0.2, 0.1, 1.2), Eigen::Vector3d(5, 5, 5)};
    values.slacks = {0.6};
  }
};

// r(values ⊞ x), x over every block's tangent coordinates.
Eigen::VectorXd At(const Graph& g, const ResidualFunction& f, const Eigen::VectorXd& x) {
  Values moved = g.values;
  Retract(g.blocks, x, &moved);
  Eigen::VectorXd r;
  EvaluateResidual(f, g.blocks, g.slots, moved, &r, nullptr);
  return r;
}

TEST_CASE("evaluate: the Jacobian is the chart's, at the values and moved by an offset",
          "[kernel]") {
  const Graph g;
  const Mixed f;
  REQUIRE(f.arity() == 16);
  Eigen::VectorXd offset(19);
  for (int i = 0; i < 19; ++i) offset[i] = 0.05 * std::sin(1.7 * i + 0.4);
  for (const bool moved : {false, true}) {
    const Eigen::VectorXd delta = moved ? offset : Eigen::VectorXd::Zero(19);
    Eigen::VectorXd r;
    Eigen::MatrixXd J;
    EvaluateResidual(f, g.blocks, g.slots, g.values, &r, &J, moved ? &offset : nullptr);
    REQUIRE(J.rows() == 7);
    REQUIRE(J.cols() == 16);
    CHECK((r - At(g, f, delta)).norm() < 1e-14);
    // Slot k's columns against differences in its block's coordinates.
    const double h = 1e-6;
    int column = 0;
    for (int b : g.slots) {
      for (int i = 0; i < TangentDim(g.blocks[b].kind); ++i, ++column) {
        Eigen::VectorXd e = Eigen::VectorXd::Zero(19);
        e[g.blocks[b].tangent_offset + i] = h;
        const Eigen::VectorXd numeric = (At(g, f, delta + e) - At(g, f, delta - e)) / (2 * h);
        INFO("moved " << moved << ", column " << column);
        CHECK((J.col(column) - numeric).norm() < 1e-8);
      }
    }
    // Without a Jacobian, the same residual; into caller storage, from slot-ordered offsets.
    Eigen::VectorXd alone;
    EvaluateResidual(f, g.blocks, g.slots, g.values, &alone, nullptr, moved ? &offset : nullptr);
    CHECK((alone - r).norm() < 1e-14);
    Eigen::VectorXd slot_offset(16);
    slot_offset << delta.segment<6>(10), delta.segment<3>(0), delta.segment<1>(9),
        delta.segment<6>(3);
    double raw[7];
    EvaluateResidualAt(f, g.blocks, g.slots, g.values, moved ? slot_offset.data() : nullptr, raw,
                       nullptr);
    CHECK((Eigen::Map<Eigen::VectorXd>(raw, 7) - r).norm() < 1e-14);
  }
}

TEST_CASE("evaluate: block states are read by kind", "[kernel]") {
  const Graph g;
  const std::vector<BlockState<double>> s =
      GatherStates(g.blocks, std::vector<int>{1, 4, 2}, g.values);
  REQUIRE(s.size() == 3);
  CHECK(s[0].R.isApprox(g.values.poses[1].RotationMatrix()));
  CHECK(s[0].t == g.values.poses[1].translation);
  CHECK(s[1].t == Eigen::Vector3d(5, 5, 5));
  CHECK(s[2].slack() == 0.6);
}

TEST_CASE("evaluate: slots that do not match the residual break the contract", "[kernel]") {
  const Graph g;
  const Mixed f;
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  CHECK_THROWS_AS(EvaluateResidual(f, g.blocks, std::vector<int>{3, 0, 2}, g.values, &r, &J),
                  InternalError);
  CHECK_THROWS_WITH(EvaluateResidual(f, g.blocks, std::vector<int>{0, 3, 2, 1}, g.values, &r, &J),
                    Catch::Contains("slot kind mismatch"));
  const Eigen::VectorXd short_offset = Eigen::VectorXd::Zero(12);
  CHECK_THROWS_AS(EvaluateResidual(f, g.blocks, g.slots, g.values, &r, &J, &short_offset),
                  InternalError);
}

}  // namespace
}  // namespace cfuse
