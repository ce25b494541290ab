// The inverse of a small lower-triangular factor, which the batch solvers need whole (the
// variances of every parameter, the covariance) and the fit analysis needs for a bound.
#pragma once

#include <Eigen/Core>

namespace cfuse {

// L⁻¹ of a lower-triangular L with a non-zero diagonal (only L's lower triangle is read),
// itself lower triangular. Forward substitution a column at a time, each step an axpy down a
// column of L: n³/6 multiply-adds, where a general triangular solve against the identity
// spends n³/2 and, at a few rows, more on its blocking than on the arithmetic.
Eigen::MatrixXd LowerTriangularInverse(const Eigen::MatrixXd& L);

}  // namespace cfuse
