// coplanar(p1, ..., pn), n >= 4: the plane through a base triple (a, b, c), with unit normal
// n̂ = normalize((b - a) × (c - a)), and one row per other point p:
//   r_p = n̂ · (p - a)              (signed distance to the plane; metres).
// n - 3 independent rows. The base triple is the one of largest triangle area at the nominal
// geometry (ties to the first in argument order), so that n̂ is as well conditioned as the
// model allows; a model whose points are all collinear at the nominal geometry is refused.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

class CoplanarResidual : public AutoDiffResidual<CoplanarResidual> {
 public:
  CoplanarResidual(BoundArgs args, std::array<int, 3> base)
      : AutoDiffResidual(static_cast<int>(args.exprs.size()) - 3, args.kinds),
        args_(std::move(args)),
        base_(base) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> a = cfuse::Evaluate<T>(*args_.exprs[base_[0]], x);
    const Vector3<T> b = cfuse::Evaluate<T>(*args_.exprs[base_[1]], x);
    const Vector3<T> c = cfuse::Evaluate<T>(*args_.exprs[base_[2]], x);
    const Vector3<T> n = (b - a).cross(c - a).normalized();
    int row = 0;
    for (int i = 0; i < static_cast<int>(args_.exprs.size()); ++i) {
      if (i == base_[0] || i == base_[1] || i == base_[2]) continue;
      r[row++] = n.dot(cfuse::Evaluate<T>(*args_.exprs[i], x) - a);
    }
  }

  std::string Describe(std::span<const std::string> names) const override;

  static ConstraintParts Create(std::vector<ExprPtr> exprs, const KindContext& ctx);

 private:
  BoundArgs args_;
  std::array<int, 3> base_;
};

}  // namespace cfuse
