// RangeResidual's factory (cfuse/constraints/kinds/range.h): an empty range is refused; the
// slack's block and its nominal value.
#include "cfuse/constraints/kinds/range.h"

#include <fmt/format.h>

#include "kinds/kind_support.h"

namespace cfuse {

ConstraintParts RangeResidual::Create(ExprPtr x, double lo, double hi, const KindContext& ctx,
                                      double* nominal_slack) {
  if (!(lo < hi)) {
    throw KindError(fmt::format("empty range: the lower bound {} is not below the upper bound {}",
                                FormatQuantity(lo, x->type.quantity),
                                FormatQuantity(hi, x->type.quantity)));
  }
  BoundArgs args = internal::BindArgs({std::move(x)}, ctx, true);
  const double v = internal::NominalValues(args, ctx)[0].x();
  const double half = 0.5 * (hi - lo), u = (v - 0.5 * (lo + hi)) / half;
  *nominal_slack = internal::NominalSlack(1 - u * u);
  std::vector<int> blocks = args.blocks;
  return {std::make_shared<RangeResidual>(std::move(args), lo, hi), std::move(blocks),
          ctx.slack_block};
}

}  // namespace cfuse
