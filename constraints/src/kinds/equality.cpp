// EqualityResidual's factory (cfuse/constraints/kinds/equality.h): a distance or a norm
// required to be 0 is refused.
#include "cfuse/constraints/kinds/equality.h"

#include "kinds/kind_support.h"

namespace cfuse {

ConstraintParts EqualityResidual::Create(ExprPtr lhs, ExprPtr rhs, const KindContext& ctx) {
  BoundArgs args = internal::BindArgs({std::move(lhs), std::move(rhs)}, ctx, false);
  // Coincident points at the nominal geometry are refused with the others not differentiable
  // there (ModelBuilder::AddConstraint).
  if (internal::NominalValues(args, ctx)[0].x() != 0)
    internal::RefuseZeroLength(*args.exprs[0], *args.exprs[1]);
  std::vector<int> blocks = args.blocks;
  return {std::make_shared<EqualityResidual>(std::move(args)), std::move(blocks)};
}

}  // namespace cfuse
