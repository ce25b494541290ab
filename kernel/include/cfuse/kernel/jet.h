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
#include <unsupported/Eigen/AutoDiff>

namespace cfuse {

inline constexpr int kJetMaxDerivatives = 6;
using JetDerivatives = Eigen::Matrix<double, kJetMaxDerivatives, 1>;
using Jet = Eigen::AutoDiffScalar<JetDerivatives>;

// The value of a double or a Jet.
inline double ValueOf(double x) { return x; }
inline double ValueOf(const Jet& x) { return x.value(); }

}  // namespace cfuse
