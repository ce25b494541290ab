// Chi-square distribution: its CDF and quantiles, for gates and consistency tests.
#pragma once

namespace cfuse {

// P(X <= x) for X ~ chi-square with `dof` degrees of freedom (the regularised lower incomplete
// gamma P(dof/2, x/2): series below a + 1, continued fraction above; relative error ~1e-14).
double ChiSquareCdf(double x, double dof);

// The x with ChiSquareCdf(x, dof) = p, for 0 < p < 1, to 1e-12 relative (safeguarded Newton).
double ChiSquareQuantile(double p, double dof);

}  // namespace cfuse
