// One checker for every Jacobian in cfuse: automatic differentiation against central
// differences taken through the same chart (cfuse/kernel/values.h), with the residual first
// filled with NaN so that a row a residual forgets to write shows up.
#pragma once

#include <catch2/catch.hpp>
#include <cmath>

#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/values.h"

namespace cfuse::testing {

inline void CheckJacobian(const std::vector<Block>& graph_blocks, const ResidualFunction& f,
                          const std::vector<int>& blocks, const Values& at) {
  int tangent_dim = 0;
  for (const Block& b : graph_blocks)
    tangent_dim = std::max(tangent_dim, b.tangent_offset + TangentDim(b.kind));
  // Every row written, and finite.
  const std::vector<BlockState<double>> states = GatherStates(graph_blocks, blocks, at);
  std::vector<double> raw(f.dimension(), std::nan(""));
  f.Evaluate(std::span<const BlockState<double>>(states), raw.data());
  for (double v : raw) REQUIRE(std::isfinite(v));

  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  EvaluateResidual(f, graph_blocks, blocks, at, &r, &J);
  REQUIRE(J.rows() == f.dimension());
  REQUIRE(J.cols() == f.arity());
  REQUIRE(J.allFinite());

  const double h = 1e-6;
  int col = 0;
  for (int b : blocks) {
    const Block& block = graph_blocks[b];
    for (int i = 0; i < TangentDim(block.kind); ++i, ++col) {
      Eigen::VectorXd delta = Eigen::VectorXd::Zero(tangent_dim);
      delta[block.tangent_offset + i] = h;
      Values plus = at, minus = at;
      Retract(graph_blocks, delta, &plus);
      Retract(graph_blocks, -delta, &minus);
      Eigen::VectorXd rp, rm;
      EvaluateResidual(f, graph_blocks, blocks, plus, &rp, nullptr);
      EvaluateResidual(f, graph_blocks, blocks, minus, &rm, nullptr);
      const Eigen::VectorXd numeric = (rp - rm) / (2 * h);
      for (int row = 0; row < f.dimension(); ++row) {
        INFO("row " << row << ", column " << col << " (block " << block.name << ", coordinate " << i
                    << "): autodiff " << J(row, col) << ", central difference " << numeric[row]);
        CHECK(std::abs(J(row, col) - numeric[row]) <= 1e-6 * (1 + std::abs(J(row, col))));
      }
    }
  }
}

}  // namespace cfuse::testing
