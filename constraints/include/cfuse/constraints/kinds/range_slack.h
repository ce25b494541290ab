// The residual of "x in [mid - half, mid + half]" in product form with slack λ:
//   1 - ((x - mid) / half)² - λ² = 0,  i.e.  (x - lo)(hi - x) / half² = λ².
// One equation and one slack per range; its gradient never vanishes: in x it is nonzero at
// both bounds (so an active bound pins x), in λ it is nonzero inside the range. Used by the
// range constraint (range.h) and the joint limit (joint_residual.h).
#pragma once

namespace cfuse {

template <typename T>
T RangeSlackResidual(const T& x, double mid, double half, const T& slack) {
  const T u = (x - T(mid)) / T(half);
  return T(1) - u * u - slack * slack;
}

}  // namespace cfuse
