// What an estimate's data say about it: how well the measurements fit (their whitened
// residuals' chi-square against its degrees of freedom) and which directions of the state the
// measurements and constraints together leave undetermined.
//
// At the estimate x, with every measurement's residual r_i, its Jacobian A_i and noise R_i, and
// every constraint's Jacobian C_k:
//   chi2 = Σ r_iᵀ R_i⁻¹ r_i over the m residual numbers of the measurements;
//   N    = a basis of C's null space: the directions in which the constraints hold (to first
//          order), the model's own degrees of freedom at x;
//   the determined directions are those of R^{-½} A N with a non-zero singular value, their
//   number the rank ρ; the others are left free by the data (a joint no measurement reaches,
//   a link turning about an axis through its only measured point);
//   dof  = m − ρ, and p = P(χ²_dof > chi2): the chance of a fit this bad or worse if the model
//          and the noise are right.
// The counts come from sparse QR (SuiteSparseQR), at a cost that follows the model's graph:
// rank C, and ρ as rank [C; R^{-½} A] − rank C, or, where every measurement reaches one block,
// as the model's degrees of freedom less the directions the blocks' measurements leave free
// and C does not hold. The basis of the free directions, when there are some, comes from the
// dense decompositions above.
// Positions are compared with rotations at the model's extent (a radian turns a point at the
// extent by the extent), so the rank does not depend on the units. Inequalities' slacks enter
// like any block: an active limit (slack at zero) then holds its joint as an equality would.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

struct Fit {
  double chi2 = 0;
  int residuals = 0;   // m
  int dof = 0;         // m − the determined directions
  double p_value = 1;  // 1 when dof is 0 (nothing to test)
};

struct FitAnalysis {
  Fit fit;
  int state_dim = 0;   // tangent dimensions of the state
  int model_dof = 0;   // of them, free under the constraints
  int determined = 0;  // of those, fixed by the measurements
  // A basis (state_dim x (model_dof − determined), tangent coordinates) of the directions the
  // measurements leave free; empty when everything is determined or when the state is larger
  // than kMaxAnalysedDim (the counts above are then still exact).
  Eigen::MatrixXd free_directions;
  // false without ranks: the fit's dof then assumes every direction allowed by the
  // constraints' row count is determined.
  bool analysed = true;
};

// The counts come from sparse QR factorisations, whose cost follows the model's graph; naming
// the free directions takes dense SVDs (~1 s at this size), done only when there are some.
inline constexpr int kMaxAnalysedDim = 1500;

// `factors`' measurements and constraints at `values`; `extent` the model's size in metres.
// Factors whose residual or Jacobian is not finite at `values` are left out.
// `ranks` false: the chi-square alone, its dof from the constraints' row count as when the
// state is too large (cheap: no Jacobian).
FitAnalysis AnalyseFit(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                       const Values& values, double extent, bool ranks = true);

// The dense counts behind AnalyseFit, in any coordinates of the state (those of a
// parametrisation that holds some constraints by construction, as interp's reduced solver's):
// `constraints` the other constraints' rows, each normalised, and `information` the whitened
// measurements' information MᵀM, its columns and rows scaled as AnalyseFit scales them. Sets the
// degrees of freedom the constraints leave and how many of them the measurements determine, and
// returns a basis of the rest (columns in these coordinates, empty when everything is determined).
Eigen::MatrixXd FreeDirections(const Eigen::MatrixXd& constraints,
                               const Eigen::MatrixXd& information, int* model_dof, int* determined);

// Whether `direction` (tangent coordinates) moves a quantity with gradient `gradient` (1 x
// state_dim): |gradient · d| above `tolerance` x |gradient| for some unit column d of `basis`.
bool MovesAlong(const Eigen::RowVectorXd& gradient, const Eigen::MatrixXd& basis,
                double tolerance = 1e-6);

}  // namespace cfuse
