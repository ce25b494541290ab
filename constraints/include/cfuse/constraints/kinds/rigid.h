// rigid(p1, ..., pn): the points keep their nominal mutual distances, as one rigid body.
//
// Candidate rows are every pairwise distance |pi - pj| - d_ij and, for every point k outside
// the base triangle (a, b, c) of largest area, the signed volume
//   ((b - a) × (c - a)) · (pk - a) - V_k      (scaled by 1 / extent² to metres).
// Distances alone leave a planar group infinitesimally flexible out of its plane and cannot
// tell a group from its mirror image; the volumes fix both. A collinear group has no base
// triangle: its candidates are instead, for every point k off the farthest pair (a, b), the two
// components of pk - a orthogonal to the line (as in collinear.h), which distances alone leave
// free to first order. From the candidates we keep, in
// that order, each row that raises the rank of the Jacobian at the nominal geometry (3n - 6
// rows for a non-degenerate group), so the constraint is full-rank by construction.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

class RigidResidual : public AutoDiffResidual<RigidResidual> {
 public:
  struct Row {
    enum class Kind { kDistance, kVolume, kLineOffset } kind = Kind::kDistance;
    // distance: i, j; volume: base i, j, k and point l; line offset: line i -> j, point l,
    // component k (0 or 1) of the offset orthogonal to the line.
    int i = 0, j = 0, k = 0, l = 0;
    double nominal = 0;
  };

  RigidResidual(BoundArgs args, std::vector<Row> rows, double volume_scale)
      : AutoDiffResidual(static_cast<int>(rows.size()), args.kinds),
        args_(std::move(args)),
        rows_(std::move(rows)),
        volume_scale_(volume_scale) {}

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    std::vector<Vector3<T>> p;
    p.reserve(args_.exprs.size());
    for (const ExprPtr& e : args_.exprs) p.push_back(cfuse::Evaluate<T>(*e, x));
    for (size_t n = 0; n < rows_.size(); ++n) {
      const Row& row = rows_[n];
      switch (row.kind) {
        case Row::Kind::kVolume: {
          const Vector3<T> normal = (p[row.j] - p[row.i]).cross(p[row.k] - p[row.i]);
          r[n] = (normal.dot(p[row.l] - p[row.i]) - T(row.nominal)) * T(volume_scale_);
          break;
        }
        case Row::Kind::kLineOffset: {
          Vector3<T> e1, e2;
          OrthonormalComplement<T>((p[row.j] - p[row.i]).normalized(), &e1, &e2);
          r[n] = (row.k == 0 ? e1 : e2).dot(p[row.l] - p[row.i]) - T(row.nominal);
          break;
        }
        case Row::Kind::kDistance:
          r[n] = (p[row.i] - p[row.j]).norm() - T(row.nominal);
          break;
      }
    }
  }

  std::string Describe(std::span<const std::string> names) const override;

  static ConstraintParts Create(std::vector<ExprPtr> exprs, const KindContext& ctx);

 private:
  BoundArgs args_;
  std::vector<Row> rows_;
  double volume_scale_;
};

}  // namespace cfuse
