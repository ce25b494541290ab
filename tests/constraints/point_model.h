// Single-point components p0, p1, ... at given positions, for the tests of the kinds'
// factories: the points as expressions, and a constraint's residual at the nominal geometry or
// with one point moved.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cfuse/constraints/kinds/kind.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse::testing {

struct PointModel {
  ModelBuilder builder{"m", "test"};
  std::vector<int> blocks;      // p_i's block
  std::vector<ExprPtr> points;  // p_i

  explicit PointModel(const std::vector<Eigen::Vector3d>& at) {
    for (size_t i = 0; i < at.size(); ++i) {
      const int c = builder.AddPointComponent("p" + std::to_string(i), at[i], {});
      blocks.push_back(builder.graph().components[c].block);
      points.push_back(MakePointRef(blocks.back()));
    }
  }

  // p_j - p_i.
  ExprPtr Vector(int i, int j) const {
    std::string why;
    return MakeBinary(Expr::Op::kSub, points[j], points[i], &why);
  }
  // distance(p_i, p_j).
  ExprPtr Distance(int i, int j) const {
    std::string why;
    return MakeCall(Function::kDistance, {points[i], points[j]}, &why);
  }

  // The nominal values, with p_i moved to `to` if i >= 0.
  Values Moved(int i, const Eigen::Vector3d& to) const {
    Values v = builder.graph().nominal;
    if (i >= 0) v.points[builder.graph().blocks[blocks[i]].index] = to;
    return v;
  }

  // The residual of `parts` at the nominal geometry (with p_i moved to `to` if i >= 0).
  Eigen::VectorXd Residual(const ConstraintParts& parts, int i = -1,
                           const Eigen::Vector3d& to = Eigen::Vector3d::Zero()) const {
    Eigen::VectorXd r;
    EvaluateResidual(*parts.residual, builder.graph().blocks, parts.blocks, Moved(i, to), &r,
                     nullptr);
    return r;
  }
};

}  // namespace cfuse::testing
