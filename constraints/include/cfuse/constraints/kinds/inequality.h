// lhs >= rhs (or lhs <= rhs) for scalars, with a slack variable λ (Hel-Or & Werman §5.1):
//   g - λ² = 0,  g = lhs - rhs (>=) or rhs - lhs (<=).
// The nominal slack is sqrt(max(g, 0)) at the nominal geometry.
#pragma once

#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

class InequalityResidual : public AutoDiffResidual<InequalityResidual> {
 public:
  InequalityResidual(BoundArgs args, bool greater)
      : AutoDiffResidual(1, args.kinds), args_(std::move(args)), greater_(greater) {}

  template <typename T>
  T Margin(std::span<const BlockState<T>> x) const {
    const T d =
        cfuse::Evaluate<T>(*args_.exprs[0], x).x() - cfuse::Evaluate<T>(*args_.exprs[1], x).x();
    return greater_ ? d : -d;
  }

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const T& slack = x.back().slack();
    r[0] = Margin(x) - slack * slack;
  }

  std::string Describe(std::span<const std::string> names) const override {
    return cfuse::Describe(*args_.exprs[0], names) + (greater_ ? " >= " : " <= ") +
           cfuse::Describe(*args_.exprs[1], names);
  }

  // Fills *nominal_slack with the slack that satisfies it at the nominal geometry.
  static ConstraintParts Create(ExprPtr lhs, ExprPtr rhs, bool greater, const KindContext& ctx,
                                double* nominal_slack);

 private:
  BoundArgs args_;
  bool greater_;
};

}  // namespace cfuse
