// RigidResidual's factory (cfuse/constraints/kinds/rigid.h): of the candidate rows, those that
// raise the rank at the nominal geometry; coinciding points are refused.
#include "cfuse/constraints/kinds/rigid.h"

#include <fmt/format.h>

#include "cfuse/constraints/evaluate.h"
#include "kinds/kind_support.h"

namespace cfuse {

std::string RigidResidual::Describe(std::span<const std::string> names) const {
  return internal::DescribeCall("rigid", args_.exprs, names);
}

ConstraintParts RigidResidual::Create(std::vector<ExprPtr> exprs, const KindContext& ctx) {
  internal::RequireVectors(exprs, "rigid", true);
  for (size_t i = 0; i < exprs.size(); ++i) {
    if (exprs[i]->op != Expr::Op::kPoint && exprs[i]->op != Expr::Op::kFeature) {
      throw KindError(fmt::format("argument {} of rigid must be a point name", i + 1));
    }
  }
  BoundArgs args = internal::BindArgs(std::move(exprs), ctx, false);
  const std::vector<Eigen::Vector3d> p = internal::NominalValues(args, ctx);
  const int n = static_cast<int>(p.size());
  const double extent = internal::Extent(p);
  if (extent <= 1e-12) throw KindError("rigid: the points coincide at the nominal geometry");
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if ((p[i] - p[j]).norm() <= 1e-9 * extent) {
        throw KindError(
            fmt::format("rigid: points {} and {} coincide at the nominal geometry", i + 1, j + 1));
      }

  std::vector<Row> candidates;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      candidates.push_back({Row::Kind::kDistance, i, j, 0, 0, (p[i] - p[j]).norm()});
  const auto [t, area] = internal::LargestTriangle(p);
  const bool collinear = area <= 1e-9 * extent * extent;
  if (n >= 4 && !collinear) {
    for (int l = 0; l < n; ++l) {
      if (l == t[0] || l == t[1] || l == t[2]) continue;
      const double v = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).dot(p[l] - p[t[0]]);
      candidates.push_back({Row::Kind::kVolume, t[0], t[1], t[2], l, v});
    }
  } else if (n >= 3 && collinear) {
    // Offsets from the line through the farthest pair.
    const auto [a, b] = internal::FarthestPair(p).first;
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

}  // namespace cfuse
