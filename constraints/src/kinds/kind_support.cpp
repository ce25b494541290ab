// What the constraint kinds' factories share (kinds/kind_support.h).
#include "kinds/kind_support.h"

#include <fmt/format.h>

#include <cmath>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/kernel/check.h"

namespace cfuse::internal {

BoundArgs BindArgs(std::vector<ExprPtr> exprs, const KindContext& ctx, bool with_slack) {
  BoundArgs out;
  out.blocks = BindSlots(&exprs);
  out.exprs = std::move(exprs);
  if (with_slack) {
    CFUSE_CHECK(ctx.slack_block >= 0);
    out.blocks.push_back(ctx.slack_block);
  }
  for (int b : out.blocks) out.kinds.push_back(ctx.blocks->at(b).kind);
  return out;
}

std::vector<Eigen::Vector3d> NominalValues(const BoundArgs& args, const KindContext& ctx) {
  const std::vector<BlockState<double>> states =
      GatherStates(*ctx.blocks, args.blocks, *ctx.nominal);
  std::vector<Eigen::Vector3d> out;
  for (const ExprPtr& e : args.exprs) {
    out.push_back(Evaluate<double>(*e, std::span<const BlockState<double>>(states)));
  }
  return out;
}

void RequireVectors(const std::vector<ExprPtr>& exprs, const char* what, bool points_only) {
  for (size_t i = 0; i < exprs.size(); ++i) {
    if (!exprs[i]->type.vector) {
      throw KindError(fmt::format("argument {} of {} must be a {}, got a {}", i + 1, what,
                                  points_only ? "point" : "vector", exprs[i]->type.ToString()));
    }
    if (points_only && !(exprs[i]->type.quantity == Quantity::Length())) {
      throw KindError(fmt::format("argument {} of {} must be a point (a length vector), got {}",
                                  i + 1, what, exprs[i]->type.ToString()));
    }
  }
}

std::string DescribeCall(const char* name, const std::vector<ExprPtr>& exprs,
                         std::span<const std::string> slot_names) {
  std::string s = std::string(name) + "(";
  for (size_t i = 0; i < exprs.size(); ++i) s += (i ? ", " : "") + Describe(*exprs[i], slot_names);
  return s + ")";
}

void RequireNonZero(const std::vector<Eigen::Vector3d>& values, const char* what) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (values[i].norm() < 1e-12) {
      throw KindError(
          fmt::format("{}: argument {} has zero length at the nominal geometry, its "
                      "direction is undefined",
                      what, i + 1));
    }
  }
}

void RefuseZeroLength(const Expr& lhs, const Expr& rhs) {
  const bool length = lhs.op == Expr::Op::kCall &&
                      (lhs.function == Function::kDistance || lhs.function == Function::kNorm);
  if (length && rhs.op == Expr::Op::kConstant && rhs.constant.isZero()) {
    throw KindError(
        "a distance or a norm required to be 0 holds only where it has no derivative, so the "
        "estimator cannot fuse it: write the points equal (a == b) or the vector zero "
        "(u == [0, 0, 0])");
  }
}

std::pair<std::array<int, 3>, double> LargestTriangle(const std::vector<Eigen::Vector3d>& p) {
  const int n = static_cast<int>(p.size());
  std::pair<std::array<int, 3>, double> best{{0, 1, 2}, -1.0};
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      for (int k = j + 1; k < n; ++k) {
        const double area = (p[j] - p[i]).cross(p[k] - p[i]).norm();
        if (area > best.second * (1 + 1e-12)) best = {{i, j, k}, area};
      }
  return best;
}

std::pair<std::array<int, 2>, double> FarthestPair(const std::vector<Eigen::Vector3d>& p) {
  const int n = static_cast<int>(p.size());
  std::pair<std::array<int, 2>, double> best{{0, 1}, -1.0};
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const double d = (p[j] - p[i]).norm();
      if (d > best.second * (1 + 1e-12)) best = {{i, j}, d};
    }
  return best;
}

double Extent(const std::vector<Eigen::Vector3d>& p) {
  double extent = 0;
  for (const Eigen::Vector3d& q : p) extent = std::max(extent, (q - p[0]).norm());
  return extent;
}

double NominalSlack(double margin) { return std::sqrt(std::max(margin, 0.0)); }

}  // namespace cfuse::internal
