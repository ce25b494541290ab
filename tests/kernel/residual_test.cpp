// The residual interface: a residual's arity is the sum of its slots' tangent dimensions, and an
// AutoDiffResidual's one Compute serves doubles and Jets alike, the Jets carrying its derivative.
#include "cfuse/kernel/residual.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <type_traits>

namespace cfuse {
namespace {

// r = s² · |p_world|², p_world a feature point of the pose: nonlinear in both slots.
class Scaled : public AutoDiffResidual<Scaled> {
 public:
  explicit Scaled(std::vector<BlockKind> kinds) : AutoDiffResidual(1, std::move(kinds)) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    const Vector3<T> p = ModelPointInWorld(x[0], true, Eigen::Vector3d(1, 0, 0));
    r[0] = x[1].slack() * x[1].slack() * p.squaredNorm();
  }
  std::string Describe(std::span<const std::string> names) const override {
    return "scaled " + names[0];
  }
};

TEST_CASE("residual: the arity sums the slots' tangent dimensions", "[kernel]") {
  CHECK(Scaled({}).arity() == 0);
  CHECK(Scaled({BlockKind::kPose, BlockKind::kSlack}).arity() == 7);
  CHECK(
      Scaled({BlockKind::kPoint, BlockKind::kPose, BlockKind::kPoint, BlockKind::kSlack}).arity() ==
      13);
  const Scaled f({BlockKind::kPose, BlockKind::kSlack});
  CHECK(f.dimension() == 1);
  CHECK(f.slot_kinds() == std::vector<BlockKind>{BlockKind::kPose, BlockKind::kSlack});
  CHECK_FALSE(f.is_linear());
  const std::string names[] = {"box", "k.slack"};
  CHECK(f.Describe(names) == "scaled box");
}

TEST_CASE("residual: one Compute for values and for derivatives", "[kernel]") {
  const Scaled f({BlockKind::kPose, BlockKind::kSlack});
  // The pose turns x onto y and moves it by (0, 1, 2): p_world = (0, 2, 2), |p|² = 8.
  BlockState<double> pose{Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                          Eigen::Vector3d(0, 1, 2)};
  BlockState<double> slack{Eigen::Matrix3d::Identity(), Eigen::Vector3d(3, 0, 0)};
  const BlockState<double> x[] = {pose, slack};
  double r = 0;
  f.Evaluate(std::span<const BlockState<double>>(x), &r);
  CHECK(r == Approx(72));  // 3² · 8
  // Jets: d r / d s = 2 s |p|² = 48, d r / d t_z = 2 s² p_z = 36.
  BlockState<Jet> jets[2];
  for (int k = 0; k < 2; ++k) {
    for (int i = 0; i < 9; ++i) jets[k].R(i) = Jet(x[k].R(i), JetDerivatives::Zero());
    for (int i = 0; i < 3; ++i) jets[k].t[i] = Jet(x[k].t[i], JetDerivatives::Zero());
  }
  jets[1].t.x().derivatives()[0] = 1;
  jets[0].t.z().derivatives()[1] = 1;
  Jet rj;
  f.Evaluate(std::span<const BlockState<Jet>>(jets), &rj);
  CHECK(rj.value() == Approx(72));
  CHECK(rj.derivatives()[0] == Approx(48));
  CHECK(rj.derivatives()[1] == Approx(36));
  CHECK(rj.derivatives()[2] == 0);
}

// Atan2 keeps a Jet's fixed derivative size (Eigen's atan2 of AutoDiffScalars does not): its
// value is std::atan2's and its derivative the finite difference's, in all four quadrants,
// for plain Jets and for expressions of them (sin and cos of one, as a joint's wrap takes).
TEST_CASE("residual: Atan2 of Jets, value and derivative", "[kernel]") {
  static_assert(std::is_same_v<decltype(Atan2(Jet(), Jet())), Jet>);
  const double h = 1e-7;
  for (const double angle : {0.3, 1.9, -2.8, -0.7, 3.1}) {
    for (const double radius : {0.2, 5.0}) {
      const double y0 = radius * std::sin(angle), x0 = radius * std::cos(angle);
      // y and x moving with two independent parameters u, v: y = y0 + u + 2v, x = x0 - 3u + v.
      const Jet u(0.0, JetDerivatives::Unit(0)), v(0.0, JetDerivatives::Unit(1));
      const Jet a = Atan2(Jet(y0) + u + 2 * v, Jet(x0) - 3 * u + v);
      INFO("angle " << angle << ", radius " << radius);
      CHECK(a.value() == std::atan2(y0, x0));
      const auto f = [&](double du, double dv) {
        return std::atan2(y0 + du + 2 * dv, x0 - 3 * du + dv);
      };
      CHECK(a.derivatives()[0] == Approx((f(h, 0) - f(-h, 0)) / (2 * h)).epsilon(1e-6));
      CHECK(a.derivatives()[1] == Approx((f(0, h) - f(0, -h)) / (2 * h)).epsilon(1e-6));
      CHECK(a.derivatives().tail<kJetMaxDerivatives - 2>().isZero());
    }
  }
  // An angle wrapped as a joint wraps it: d/dθ atan2(sin θ, cos θ) = 1 off the cut.
  for (const double theta : {0.4, 2.5, 4.0, -3.0}) {
    const Jet t(theta, JetDerivatives::Unit(3));
    using std::cos, std::sin;
    const Jet wrapped = Atan2(sin(t), cos(t));
    CHECK(wrapped.value() == Approx(std::remainder(theta, 2 * M_PI)).margin(1e-15));
    CHECK(wrapped.derivatives()[3] == Approx(1.0).epsilon(1e-14));
  }
  CHECK(Atan2(1.0, -1.0) == std::atan2(1.0, -1.0));
}

}  // namespace
}  // namespace cfuse
