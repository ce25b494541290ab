// Gating and scoring in the interpretation tree (interp/src/interpreter_gating.cpp), through
// Interpret on a rigid box whose corners are measured exactly but one: the δ a candidate is
// scored by is a Mahalanobis distance (quadratic in the measurement's offset, in 3D and in an
// image), and a measurement beyond the chi-square gate of its point's prediction is not
// matched.
#include <algorithm>
#include <catch2/catch.hpp>
#include <optional>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/kernel/chi_square.h"
#include "test_util.h"

namespace cfuse {
namespace {

// Eight corners of a skewed box: no turn of it maps its corners onto one another, so only one
// labelling fits.
ConstraintGraph Box() {
  return LoadModelFromString(
      "name: box\nunits: {length: mm}\ncomponents:\n  box:\n    points: {c000: [0, 0, 0], "
      "c100: [300, 0, 0], c110: [310, 200, 0], c010: [0, 180, 0], c001: [0, 10, 100], "
      "c101: [290, 0, 120], c111: [300, 210, 90], c011: [-20, 200, 110]}\n",
      "box.yaml", ".");
}

const Rigid3d kPose(Eigen::Quaterniond(Eigen::AngleAxisd(0.6,
                                                         Eigen::Vector3d(1, -2, 1).normalized())),
                    Eigen::Vector3d(-0.1, 0.05, 1.2));

// The box's corners at kPose measured exactly (1 mm in 3D, 1 px in the image), corner
// `moved` shifted by `offset` (m, or px).
MeasurementSet Corners(const ConstraintGraph& g, int moved, const Eigen::Vector3d& offset,
                       bool image) {
  MeasurementSet set;
  if (image) set.camera = testing::Pinhole();
  const Component& box = g.components[0];
  for (size_t f = 0; f < box.points.size(); ++f) {
    MeasuredPoint m;
    const Eigen::Vector3d p = kPose * box.points[f].position;
    const Eigen::Vector3d shift = static_cast<int>(f) == moved ? offset : Eigen::Vector3d::Zero();
    m.is_3d = !image;
    m.xyz = p + shift;
    m.cov3 = 1e-6 * Eigen::Matrix3d::Identity();
    if (image) m.uv = set.camera->Project<double>(p) + shift.head<2>();
    m.cov2 = Eigen::Matrix2d::Identity();
    set.points.push_back(m);
  }
  return set;
}

// The δ of measurement `m` where the tree matched it, or nothing when it is not matched there.
std::optional<double> DeltaOf(const Interpretation& in, int m) {
  for (const TraceLevel& t : in.trace) {
    if (t.chosen != m) continue;
    for (const auto& [candidate, delta] : t.best) {
      if (candidate == m) return delta;
    }
  }
  return std::nullopt;
}

TEST_CASE("gating: a candidate's δ is quadratic in its offset from the prediction", "[interp]") {
  const ConstraintGraph g = Box();
  const int moved = 6;  // c111, matched after the seed
  for (const bool image : {false, true}) {
    CAPTURE(image);
    // 1.5 and 3 noise sigmas off, along a direction not special to the box.
    const double sigma = image ? 1.0 : 0.001;
    const Eigen::Vector3d u = Eigen::Vector3d(0.6, -0.8, image ? 0 : 0.5).normalized();
    const Interpretation near = Interpret(g, Corners(g, moved, 1.5 * sigma * u, image));
    const Interpretation far = Interpret(g, Corners(g, moved, 3 * sigma * u, image));
    REQUIRE(near.matched == 8);
    REQUIRE(far.matched == 8);
    const std::optional<double> a = DeltaOf(near, moved), b = DeltaOf(far, moved);
    REQUIRE(a);
    REQUIRE(b);
    REQUIRE(*a > 0);  // not a seed's own match (δ 0)
    // δ = dᵀ (P + Λ)⁻¹ d with P the prediction's covariance from the exact corners before it:
    // below d²/σ², above half of it (P is smaller than Λ), four times as large at twice d.
    CHECK(*a < 1.5 * 1.5);
    CHECK(*a > 0.5 * 1.5 * 1.5);
    CHECK(*b == Approx(4 * *a).epsilon(1e-3));
  }
}

TEST_CASE("gating: a measurement beyond the gate of its point's prediction is not matched",
          "[interp]") {
  const ConstraintGraph g = Box();
  const int moved = 6;
  const Eigen::Vector3d u = Eigen::Vector3d(0.6, -0.8, 0.5).normalized();
  // 4 sigmas: δ about 16 or less, inside the 3-row gate at 0.9999 (21.1).
  REQUIRE(ChiSquareQuantile(0.9999, 3) == Approx(21.11).margin(0.01));
  const Interpretation inside = Interpret(g, Corners(g, moved, 0.004 * u, false));
  CHECK(inside.matched == 8);
  CHECK(inside.matches[moved] == "box.c111");
  // 12 sigmas: δ above 72, outside; the other seven corners are matched all the same.
  const Interpretation outside = Interpret(g, Corners(g, moved, 0.012 * u, false));
  CHECK(outside.matched == 7);
  CHECK(outside.matches[moved].empty());
  for (int m = 0; m < 8; ++m) {
    if (m != moved)
      CHECK(outside.matches[m] == g.components[0].name + "." + g.components[0].points[m].name);
  }
}

}  // namespace
}  // namespace cfuse
