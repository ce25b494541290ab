// perpendicular(u, v): r = û · v̂ (the cosine of the angle; one row, dimensionless).
#pragma once

#include <fmt/format.h>

#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

class PerpendicularResidual : public AutoDiffResidual<PerpendicularResidual> {
 public:
  explicit PerpendicularResidual(BoundArgs args)
      : AutoDiffResidual(1, args.kinds), args_(std::move(args)) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    r[0] = cfuse::Evaluate<T>(*args_.exprs[0], x)
               .normalized()
               .dot(cfuse::Evaluate<T>(*args_.exprs[1], x).normalized());
  }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("perpendicular({}, {})", cfuse::Describe(*args_.exprs[0], names),
                       cfuse::Describe(*args_.exprs[1], names));
  }

  static ConstraintParts Create(std::vector<ExprPtr> exprs, const KindContext& ctx);

 private:
  BoundArgs args_;
};

}  // namespace cfuse
