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

#include <fmt/format.h>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/kinds/kind_support.h"

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

  std::string Describe(std::span<const std::string> names) const override {
    return DescribeCall("rigid", args_.exprs, names);
  }

  static ConstraintParts Create(std::vector<ExprPtr> exprs, const KindContext& ctx) {
    RequireVectors(exprs, "rigid", true);
    for (size_t i = 0; i < exprs.size(); ++i) {
      if (exprs[i]->op != Expr::Op::kPoint && exprs[i]->op != Expr::Op::kFeature) {
        throw KindError(fmt::format("argument {} of rigid must be a point name", i + 1));
      }
    }
    BoundArgs args = BindArgs(std::move(exprs), ctx, false);
    const std::vector<Eigen::Vector3d> p = NominalValues(args, ctx);
    const int n = static_cast<int>(p.size());
    const double extent = Extent(p);
    if (extent <= 1e-12) throw KindError("rigid: the points coincide at the nominal geometry");
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        if ((p[i] - p[j]).norm() <= 1e-9 * extent) {
          throw KindError(fmt::format("rigid: points {} and {} coincide at the nominal geometry",
                                      i + 1, j + 1));
        }

    std::vector<Row> candidates;
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        candidates.push_back({Row::Kind::kDistance, i, j, 0, 0, (p[i] - p[j]).norm()});
    const auto [t, area] = LargestTriangle(p);
    const bool collinear = area <= 1e-9 * extent * extent;
    if (n >= 4 && !collinear) {
      for (int l = 0; l < n; ++l) {
        if (l == t[0] || l == t[1] || l == t[2]) continue;
        const double v = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).dot(p[l] - p[t[0]]);
        candidates.push_back({Row::Kind::kVolume, t[0], t[1], t[2], l, v});
      }
    } else if (n >= 3 && collinear) {
      // Offsets from the line through the farthest pair.
      const auto [a, b] = FarthestPair(p).first;
      Eigen::Vector3d e1, e2;
      OrthonormalComplement<double>((p[b] - p[a]).normalized(), &e1, &e2);
      for (int l = 0; l < n; ++l) {
        if (l == a || l == b) continue;
        candidates.push_back({Row::Kind::kLineOffset, a, b, 0, l, e1.dot(p[l] - p[a])});
        candidates.push_back({Row::Kind::kLineOffset, a, b, 1, l, e2.dot(p[l] - p[a])});
      }
    }
    const double volume_scale = 1.0 / (extent * extent);

    // Keep the rows that raise the rank (Gram-Schmidt, twice for stability).
    const RigidResidual all(args, candidates, volume_scale);
    Eigen::VectorXd r;
    Eigen::MatrixXd J;
    EvaluateResidual(all, *ctx.blocks, args.blocks, *ctx.nominal, &r, &J);
    std::vector<Eigen::VectorXd> basis;
    std::vector<Row> rows;
    for (int c = 0; c < J.rows(); ++c) {
      Eigen::VectorXd v = J.row(c).transpose();
      const double norm0 = v.norm();
      if (norm0 <= 1e-12) continue;
      for (int pass = 0; pass < 2; ++pass)
        for (const Eigen::VectorXd& q : basis) v -= q.dot(v) * q;
      if (v.norm() > 1e-8 * norm0) {
        basis.push_back(v.normalized());
        rows.push_back(candidates[c]);
      }
    }
    if (rows.empty()) {
      throw KindError(
          "rigid: the points already belong to one rigid component, so the "
          "constraint adds nothing");
    }
    std::vector<int> blocks = args.blocks;
    return {std::make_shared<RigidResidual>(std::move(args), std::move(rows), volume_scale),
            std::move(blocks)};
  }

 private:
  BoundArgs args_;
  std::vector<Row> rows_;
  double volume_scale_;
};

}  // namespace cfuse
