// lhs == rhs for scalar or vector expressions: r = lhs - rhs (1 or 3 rows).
// Fixing a point in the world is `p == [x, y, z] m`.
#pragma once

#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

class EqualityResidual : public AutoDiffResidual<EqualityResidual> {
 public:
  EqualityResidual(BoundArgs args)
      : AutoDiffResidual(args.exprs[0]->type.vector ? 3 : 1, args.kinds), args_(std::move(args)) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> d =
        cfuse::Evaluate<T>(*args_.exprs[0], x) - cfuse::Evaluate<T>(*args_.exprs[1], x);
    for (int i = 0; i < dimension(); ++i) r[i] = d[i];
  }

  std::string Describe(std::span<const std::string> names) const override {
    return cfuse::Describe(*args_.exprs[0], names) +
           " == " + cfuse::Describe(*args_.exprs[1], names);
  }

  // lhs and rhs of the same type (checked by the caller).
  static ConstraintParts Create(ExprPtr lhs, ExprPtr rhs, const KindContext& ctx);

 private:
  BoundArgs args_;
};

}  // namespace cfuse
