// The forward-mode automatic-differentiation scalar of cfuse.
//
// Jet is Eigen's AutoDiffScalar with a fixed derivative vector of kJetMaxDerivatives entries,
// so it lives on the stack and its arithmetic compiles to straight vector code (a runtime-sized
// derivative vector cost a library call per copy). A constraint of arity n (the tangent
// dimension of the blocks it touches: 3 per point, 6 per pose, 1 per slack) is differentiated
// in one evaluation when n <= kJetMaxDerivatives, the unused entries staying zero, and in
// chunks of kJetMaxDerivatives otherwise (as Ceres' DynamicAutoDiffCostFunction does with its
// stride). 12 covers most kinds in one evaluation: a distance between points (6), a joint
// between two poses (12), coplanarity of four points (12). One Jet type keeps every residual
// instantiated twice only (double and Jet).
#pragma once

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>

namespace cfuse {

inline constexpr int kJetMaxDerivatives = 12;
using JetDerivatives = Eigen::Matrix<double, kJetMaxDerivatives, 1>;
using Jet = Eigen::AutoDiffScalar<JetDerivatives>;

// The value of a double or a Jet.
inline double ValueOf(double x) { return x; }
inline double ValueOf(const Jet& x) { return x.value(); }

}  // namespace cfuse
