// parallel(u, v): the directions of two vectors agree up to sign. u × v = 0 has 3 rows but
// rank 2, so we write the 2 independent ones: with (e1, e2) an orthonormal basis of the plane
// orthogonal to û,
//   r = [e1 · v̂, e2 · v̂]          (the sines of the angle's two components; dimensionless).
// The basis depends on û, but its derivative multiplies e·v̂ = 0 at a solution, so the
// Jacobian there is exact and of rank 2.
#pragma once

#include <fmt/format.h>

#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

class ParallelResidual : public AutoDiffResidual<ParallelResidual> {
 public:
  explicit ParallelResidual(BoundArgs args)
      : AutoDiffResidual(2, args.kinds), args_(std::move(args)) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> u = cfuse::Evaluate<T>(*args_.exprs[0], x).normalized();
    const Vector3<T> v = cfuse::Evaluate<T>(*args_.exprs[1], x).normalized();
    Vector3<T> e1, e2;
    OrthonormalComplement<T>(u, &e1, &e2);
    r[0] = e1.dot(v);
    r[1] = e2.dot(v);
  }

  std::string Describe(std::span<const std::string> names) const override {
    return fmt::format("parallel({}, {})", cfuse::Describe(*args_.exprs[0], names),
                       cfuse::Describe(*args_.exprs[1], names));
  }

  static ConstraintParts Create(std::vector<ExprPtr> exprs, const KindContext& ctx);

 private:
  BoundArgs args_;
};

}  // namespace cfuse
