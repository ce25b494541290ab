// PerpendicularResidual's factory (cfuse/constraints/kinds/perpendicular.h): two vectors, each
// of nonzero length at the nominal geometry.
#include "cfuse/constraints/kinds/perpendicular.h"

#include "kinds/kind_support.h"

namespace cfuse {

ConstraintParts PerpendicularResidual::Create(std::vector<ExprPtr> exprs, const KindContext& ctx) {
  internal::RequireVectors(exprs, "perpendicular", false);
  BoundArgs args = internal::BindArgs(std::move(exprs), ctx, false);
  const std::vector<Eigen::Vector3d> v = internal::NominalValues(args, ctx);
  internal::RequireNonZero(v, "perpendicular");
  std::vector<int> blocks = args.blocks;
  return {std::make_shared<PerpendicularResidual>(std::move(args)), std::move(blocks)};
}

}  // namespace cfuse
