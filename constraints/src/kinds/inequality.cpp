// InequalityResidual's factory (cfuse/constraints/kinds/inequality.h): the slack's block and
// its nominal value; a distance or a norm required to be <= 0 is refused.
#include "cfuse/constraints/kinds/inequality.h"

#include "kinds/kind_support.h"

namespace cfuse {

ConstraintParts InequalityResidual::Create(ExprPtr lhs, ExprPtr rhs, bool greater,
                                           const KindContext& ctx, double* nominal_slack) {
  BoundArgs args = internal::BindArgs({std::move(lhs), std::move(rhs)}, ctx, true);
  const std::vector<Eigen::Vector3d> v = internal::NominalValues(args, ctx);
  if (!greater && v[0].x() != 0) internal::RefuseZeroLength(*args.exprs[0], *args.exprs[1]);
  *nominal_slack = internal::NominalSlack(greater ? v[0].x() - v[1].x() : v[1].x() - v[0].x());
  std::vector<int> blocks = args.blocks;
  return {std::make_shared<InequalityResidual>(std::move(args), greater), std::move(blocks),
          ctx.slack_block};
}

}  // namespace cfuse
