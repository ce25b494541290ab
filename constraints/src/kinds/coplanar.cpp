// CoplanarResidual's factory (cfuse/constraints/kinds/coplanar.h): the triple of largest
// triangle at the nominal geometry is the plane's base; points without a plane are refused.
#include "cfuse/constraints/kinds/coplanar.h"

#include "kinds/kind_support.h"

namespace cfuse {

std::string CoplanarResidual::Describe(std::span<const std::string> names) const {
  return internal::DescribeCall("coplanar", args_.exprs, names);
}

ConstraintParts CoplanarResidual::Create(std::vector<ExprPtr> exprs, const KindContext& ctx) {
  internal::RequireVectors(exprs, "coplanar", true);
  BoundArgs args = internal::BindArgs(std::move(exprs), ctx, false);
  const std::vector<Eigen::Vector3d> p = internal::NominalValues(args, ctx);
  const auto [base, area] = internal::LargestTriangle(p);
  const double extent = internal::Extent(p);
  if (area <= 1e-9 * extent * extent || extent == 0) {
    throw KindError(
        "coplanar: the points are collinear (or coincide) at the nominal geometry, so they "
        "do not define a plane");
  }
  std::vector<int> blocks = args.blocks;
  return {std::make_shared<CoplanarResidual>(std::move(args), base), std::move(blocks)};
}

}  // namespace cfuse
