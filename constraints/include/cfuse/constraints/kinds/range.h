// x in [lo, hi] for a scalar expression with constant bounds, in product form with one slack:
//   (x - lo)(hi - x) / half² - λ² = 0,   half = (hi - lo) / 2.
// Why one product equation rather than two one-sided inequalities: one slack instead of two,
// and the row's gradient never vanishes (kind_support.h, RangeSlackResidual).
#pragma once

#include <fmt/format.h>

#include "cfuse/constraints/kinds/kind_support.h"

namespace cfuse {

class RangeResidual : public AutoDiffResidual<RangeResidual> {
 public:
  RangeResidual(BoundArgs args, double lo, double hi)
      : AutoDiffResidual(1, args.kinds), args_(std::move(args)), lo_(lo), hi_(hi) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    r[0] = RangeSlackResidual(cfuse::Evaluate<T>(*args_.exprs[0], x).x(), 0.5 * (lo_ + hi_),
                              0.5 * (hi_ - lo_), x.back().slack());
  }

  std::string Describe(std::span<const std::string> names) const override {
    const Quantity q = args_.exprs[0]->type.quantity;
    return fmt::format("{} in [{}, {}]", cfuse::Describe(*args_.exprs[0], names),
                       FormatQuantity(lo_, q), FormatQuantity(hi_, q));
  }

  static ConstraintParts Create(ExprPtr x, double lo, double hi, const KindContext& ctx,
                                double* nominal_slack) {
    if (!(lo < hi)) {
      throw KindError(fmt::format("empty range: the lower bound {} is not below the upper bound {}",
                                  FormatQuantity(lo, x->type.quantity),
                                  FormatQuantity(hi, x->type.quantity)));
    }
    BoundArgs args = BindArgs({std::move(x)}, ctx, true);
    const double v = NominalValues(args, ctx)[0].x();
    const double half = 0.5 * (hi - lo), u = (v - 0.5 * (lo + hi)) / half;
    *nominal_slack = NominalSlack(1 - u * u);
    std::vector<int> blocks = args.blocks;
    return {std::make_shared<RangeResidual>(std::move(args), lo, hi), std::move(blocks),
            ctx.slack_block};
  }

 private:
  BoundArgs args_;
  double lo_, hi_;
};

}  // namespace cfuse
