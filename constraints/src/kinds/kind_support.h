// What the constraint kinds' factories (src/kinds/<kind>.cpp) share: binding arguments to
// slots, their values at the nominal geometry, the refusals every kind makes (thrown as
// KindError, cfuse/constraints/kinds/kind.h), the description of a call, the base points of a
// group and the nominal slack. Internal to the constraints library.
#pragma once

#include <Eigen/Core>
#include <array>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "cfuse/constraints/expr.h"
#include "cfuse/constraints/kinds/kind.h"

namespace cfuse::internal {

BoundArgs BindArgs(std::vector<ExprPtr> exprs, const KindContext& ctx, bool with_slack);

// Values of bound expressions at the nominal geometry.
std::vector<Eigen::Vector3d> NominalValues(const BoundArgs& args, const KindContext& ctx);

// Every argument must be a vector (points or directions); `what` names the kind in messages.
void RequireVectors(const std::vector<ExprPtr>& exprs, const char* what, bool points_only);

// "name(arg1, arg2, ...)" for relations written as calls.
std::string DescribeCall(const char* name, const std::vector<ExprPtr>& exprs,
                         std::span<const std::string> slot_names);

// Refuses arguments that have zero length at the nominal geometry (their direction is
// undefined there).
void RequireNonZero(const std::vector<Eigen::Vector3d>& values, const char* what);

// Refuses `distance(a, b)` or `norm(u)` required to be 0 (== 0, <= 0): it holds only where the
// length has no derivative, so a solve could never fuse it (`a == b` says the same, with a
// derivative everywhere).
void RefuseZeroLength(const Expr& lhs, const Expr& rhs);

// The triple of points spanning the largest triangle (ties to the first in argument order)
// and its doubled area; the pair farthest apart and its distance; the largest distance from
// the first point (the group's extent).
std::pair<std::array<int, 3>, double> LargestTriangle(const std::vector<Eigen::Vector3d>& p);
std::pair<std::array<int, 2>, double> FarthestPair(const std::vector<Eigen::Vector3d>& p);
double Extent(const std::vector<Eigen::Vector3d>& p);

// The nominal slack of a range or a one-sided inequality whose normalised margin is `margin`
// (>= 0 inside): sqrt(max(margin, 0)) (the slack form is cfuse/constraints/kinds/range_slack.h).
double NominalSlack(double margin);

}  // namespace cfuse::internal
