// What every constraint kind's factory shares: the context it is built in, what it returns,
// and how it reports a constraint that cannot be built (degenerate at the nominal geometry,
// wrong argument types). KindError carries only the message; the caller (DSL, importer)
// knows where in the user's file the constraint was written and wraps it into an InputError.
#pragma once

#include <array>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "cfuse/constraints/expr.h"
#include "cfuse/kernel/residual.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

class KindError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct KindContext {
  const std::vector<Block>* blocks = nullptr;  // the graph's blocks so far
  const Values* nominal = nullptr;             // their nominal values
  int slack_block = -1;  // the block reserved for this constraint's slack, if it needs one
};

struct ConstraintParts {
  std::shared_ptr<const ResidualFunction> residual;
  std::vector<int> blocks;  // slot -> block id
  int slack_block = -1;
};

// Expressions bound to local slots, with their blocks and the blocks' kinds.
struct BoundArgs {
  std::vector<ExprPtr> exprs;
  std::vector<int> blocks;
  std::vector<BlockKind> kinds;
};

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

// The residual of "x in [mid - half, mid + half]" in product form with slack λ:
//   1 - ((x - mid) / half)² - λ² = 0,  i.e.  (x - lo)(hi - x) / half² = λ².
// One equation and one slack per range; its gradient never vanishes: in x it is nonzero at
// both bounds (so an active bound pins x), in λ it is nonzero inside the range.
template <typename T>
T RangeSlackResidual(const T& x, double mid, double half, const T& slack) {
  const T u = (x - T(mid)) / T(half);
  return T(1) - u * u - slack * slack;
}

// The nominal slack of a range or a one-sided inequality whose normalised margin is `margin`
// (>= 0 inside): sqrt(max(margin, 0)).
double NominalSlack(double margin);

}  // namespace cfuse
