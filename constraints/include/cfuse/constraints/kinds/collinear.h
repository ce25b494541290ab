// collinear(p1, ..., pn), n >= 3: the line through a base pair (a, b) with direction
// d̂ = normalize(b - a), and for every other point p the two components of p - a orthogonal
// to d̂, in an orthonormal basis (e1, e2) of the plane orthogonal to d̂:
//   r_p = [e1 · (p - a), e2 · (p - a)]      (metres; 2 rows per point, 2(n - 2) in all).
// (p - a) × d̂ would give 3 rows of rank 2 per point. The base pair is the farthest apart at
// the nominal geometry; the basis' own derivative multiplies a zero at a solution.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

class CollinearResidual : public AutoDiffResidual<CollinearResidual> {
 public:
  CollinearResidual(BoundArgs args, std::array<int, 2> base)
      : AutoDiffResidual(2 * (static_cast<int>(args.exprs.size()) - 2), args.kinds),
        args_(std::move(args)),
        base_(base) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> a = cfuse::Evaluate<T>(*args_.exprs[base_[0]], x);
    const Vector3<T> d = (cfuse::Evaluate<T>(*args_.exprs[base_[1]], x) - a).normalized();
    Vector3<T> e1, e2;
    OrthonormalComplement<T>(d, &e1, &e2);
    int row = 0;
    for (int i = 0; i < static_cast<int>(args_.exprs.size()); ++i) {
      if (i == base_[0] || i == base_[1]) continue;
      const Vector3<T> ap = cfuse::Evaluate<T>(*args_.exprs[i], x) - a;
      r[row++] = e1.dot(ap);
      r[row++] = e2.dot(ap);
    }
  }

  std::string Describe(std::span<const std::string> names) const override;

  static ConstraintParts Create(std::vector<ExprPtr> exprs, const KindContext& ctx);

 private:
  BoundArgs args_;
  std::array<int, 2> base_;
};

}  // namespace cfuse
