// CollinearResidual's factory (cfuse/constraints/kinds/collinear.h): the pair farthest apart
// at the nominal geometry is the line's base; points that all coincide are refused.
#include "cfuse/constraints/kinds/collinear.h"

#include "kinds/kind_support.h"

namespace cfuse {

std::string CollinearResidual::Describe(std::span<const std::string> names) const {
  return internal::DescribeCall("collinear", args_.exprs, names);
}

ConstraintParts CollinearResidual::Create(std::vector<ExprPtr> exprs, const KindContext& ctx) {
  internal::RequireVectors(exprs, "collinear", true);
  BoundArgs args = internal::BindArgs(std::move(exprs), ctx, false);
  const std::vector<Eigen::Vector3d> p = internal::NominalValues(args, ctx);
  const auto [base, distance] = internal::FarthestPair(p);
  if (distance <= 1e-12) {
    throw KindError(
        "collinear: the points coincide at the nominal geometry, so they do not "
        "define a line");
  }
  std::vector<int> blocks = args.blocks;
  return {std::make_shared<CollinearResidual>(std::move(args), base), std::move(blocks)};
}

}  // namespace cfuse
