// The forward-mode automatic-differentiation scalar of cfuse.
//
// Jet is Eigen's AutoDiffScalar with a fixed derivative vector of kJetMaxDerivatives entries,
// so it lives on the stack and its arithmetic compiles to straight vector code (a runtime-sized
// derivative vector cost a library call per copy). A residual of arity n (the tangent dimension
// of the blocks it touches: 3 per point, 6 per pose, 1 per slack) is differentiated in one
// evaluation when n <= kJetMaxDerivatives, the unused entries staying zero, and in chunks of
// kJetMaxDerivatives otherwise (as Ceres' DynamicAutoDiffCostFunction does with its stride).
// Six entries cover one pose or two points in one evaluation: the distances that make up most
// models, and measurements of a rigid component. Twelve made every Jet operation twice as
// costly for those and saved one evaluation for joints between two poses (measured in
// docs/benchmarks.md: the lamp's fusion pass 103 -> 95 µs, a revolute joint 1.3 -> 2.0 µs).
// One Jet type keeps every residual instantiated twice only (double and Jet).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <unsupported/Eigen/AutoDiff>

namespace cfuse {

inline constexpr int kJetMaxDerivatives = 6;
using JetDerivatives = Eigen::Matrix<double, kJetMaxDerivatives, 1>;
using Jet = Eigen::AutoDiffScalar<JetDerivatives>;

// The value of a double or a Jet.
inline double ValueOf(double x) { return x; }
inline double ValueOf(const Jet& x) { return x.value(); }

// atan2(y, x) of doubles, or of AutoDiffScalars with a fixed-size derivative vector (a Jet, or
// an expression of Jets), keeping that size. Eigen's own atan2 of AutoDiffScalars returns a
// runtime-sized derivative vector: a heap allocation per call, in every revolute joint's angle.
// The derivative is Eigen's to the last bit (its order of operations): a solve that rejects a
// 10^6-sigma outlier in an image was seen to fail on a change in the last bit alone.
inline double Atan2(double y, double x) { return std::atan2(y, x); }
template <typename DerY, typename DerX>
auto Atan2(const Eigen::AutoDiffScalar<DerY>& y, const Eigen::AutoDiffScalar<DerX>& x) {
  using Derivatives = typename Eigen::internal::remove_all<DerY>::type::PlainObject;
  const double yv = y.value(), xv = x.value();
  const double norm2 = yv * yv + xv * xv;  // d atan2 = (x dy - y dx) / (x² + y²)
  Derivatives d = (y.derivatives() * xv - yv * x.derivatives()) / norm2;
  return Eigen::AutoDiffScalar<Derivatives>(std::atan2(yv, xv), d);
}

}  // namespace cfuse
