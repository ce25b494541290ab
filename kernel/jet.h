// The forward-mode automatic-differentiation scalar of cfuse.
//
// Jet is Eigen's AutoDiffScalar whose derivative vector has a runtime size with a fixed
// maximum (kJetMaxDerivatives), so it lives on the stack: a constraint of arity n (the tangent
// dimension of the blocks it touches: 3 per point, 6 per pose, 1 per slack) is differentiated
// with derivative vectors of exactly n entries when n <= kJetMaxDerivatives, and in chunks of
// kJetMaxDerivatives otherwise (as Ceres' DynamicAutoDiffCostFunction does with its stride).
// One Jet type keeps every residual instantiated twice only (double and Jet).
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
