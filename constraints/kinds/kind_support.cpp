#include "constraints/kinds/kind_support.h"

#include <fmt/format.h>

#include <cmath>

#include "constraints/evaluate.h"
#include "kernel/check.h"

namespace cfuse {

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

double NominalSlack(double margin) { return std::sqrt(std::max(margin, 0.0)); }

}  // namespace cfuse
