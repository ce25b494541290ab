// x in [lo, hi] for a scalar expression with constant bounds, in product form with one slack:
//   (x - lo)(hi - x) / half² - λ² = 0,   half = (hi - lo) / 2.
// Why one product equation rather than two one-sided inequalities: one slack instead of two,
// and the row's gradient never vanishes (range_slack.h).
#pragma once

#include <fmt/format.h>

#include "cfuse/constraints/kinds/kind.h"
#include "cfuse/constraints/kinds/range_slack.h"

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
                                double* nominal_slack);

 private:
  BoundArgs args_;
  double lo_, hi_;
};

}  // namespace cfuse
