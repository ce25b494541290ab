// ParallelResidual's factory (cfuse/constraints/kinds/parallel.h): two vectors, each of
// nonzero length at the nominal geometry.
#include "cfuse/constraints/kinds/parallel.h"

#include "kinds/kind_support.h"

namespace cfuse {

ConstraintParts ParallelResidual::Create(std::vector<ExprPtr> exprs, const KindContext& ctx) {
  internal::RequireVectors(exprs, "parallel", false);
  BoundArgs args = internal::BindArgs(std::move(exprs), ctx, false);
  const std::vector<Eigen::Vector3d> v = internal::NominalValues(args, ctx);
  internal::RequireNonZero(v, "parallel");
  std::vector<int> blocks = args.blocks;
  return {std::make_shared<ParallelResidual>(std::move(args)), std::move(blocks)};
}

}  // namespace cfuse
