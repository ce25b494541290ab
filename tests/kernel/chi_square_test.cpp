// The chi-square CDF and quantile (cfuse/kernel/chi_square.h) against closed forms and each other.
#include "cfuse/kernel/chi_square.h"

#include <catch2/catch.hpp>
#include <cmath>

namespace cfuse {
namespace {

TEST_CASE("chi-square: quantiles match closed forms") {
  // Two degrees of freedom: the CDF is 1 - exp(-x/2), so the quantile is -2 log(1 - p).
  for (double p : {1e-6, 0.005, 0.5, 0.9, 0.99, 0.9999}) {
    CHECK(ChiSquareQuantile(p, 2) == Approx(-2 * std::log1p(-p)).epsilon(1e-11));
  }
  // Far in the tail the CDF, computed as 1 - Q, resolves x only to about 1e-16 / (1 - p).
  CHECK(ChiSquareQuantile(1 - 1e-9, 2) == Approx(-2 * std::log(1e-9)).epsilon(1e-6));
  // One degree of freedom: the square of the normal quantile at (1 + p) / 2.
  CHECK(ChiSquareQuantile(0.95, 1) == Approx(1.959963984540054 * 1.959963984540054).epsilon(1e-11));
  CHECK(ChiSquareQuantile(0.99, 1) ==
        Approx(2.5758293035489004 * 2.5758293035489004).epsilon(1e-11));
}

TEST_CASE("chi-square: the quantile inverts the CDF over dof and confidence") {
  for (double dof : {0.5, 1.0, 2.0, 3.0, 6.0, 23.0, 100.0, 400.0, 5000.0}) {
    for (double p : {1e-4, 0.005, 0.1, 0.5, 0.9, 0.995, 0.9999}) {
      INFO("dof " << dof << ", p " << p);
      const double x = ChiSquareQuantile(p, dof);
      CHECK(ChiSquareCdf(x, dof) == Approx(p).epsilon(1e-9));
    }
  }
  // The 99 % interval the tests use for 400 DOF.
  CHECK(ChiSquareQuantile(0.005, 400) == Approx(330.9).epsilon(1e-3));
  CHECK(ChiSquareQuantile(0.995, 400) == Approx(476.6).epsilon(1e-3));
}

}  // namespace
}  // namespace cfuse
