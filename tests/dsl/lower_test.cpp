// Lowering constraint text to the graph (dsl/src/lower.cpp), on a model built in code: each
// relation becomes its kind with `nominal` and units resolved; every refusal lands at the
// character it names when the text sits verbatim in its file, else at the text's start; and
// constant quantities such as limits.
#include "lower.h"

#include <fmt/format.h>

#include <catch2/catch.hpp>
#include <cmath>

#include "cfuse/kernel/evaluate.h"

namespace cfuse {
namespace {

// Points a, b, c; rigid arm and leg, both with a point 'tip'; arm with 'root' too.
struct Model {
  ModelBuilder b{"m", "m.yaml"};
  Model() {
    b.AddPointComponent("a", {0, 0, 0}, {});
    b.AddPointComponent("b", {0.3, 0.4, 0}, {});
    b.AddPointComponent("c", {0, 0, 1}, {});
    const int arm = b.AddRigidComponent("arm", Rigid3d(), {});
    b.AddFeaturePoint(arm, "tip", {1, 0, 0}, {});
    b.AddFeaturePoint(arm, "root", {0, 0, 0}, {});
    const int leg = b.AddRigidComponent("leg", Rigid3d(), {});
    b.AddFeaturePoint(leg, "tip", {0, -1, 0}, {});
  }
  // The constraint `text` at line 5, column 10 of m.yaml.
  const Constraint& Add(const std::string& text, bool exact = true, const std::string& name = "k") {
    Lowerer(b, TextOrigin{"m.yaml", 5, 10, exact}).AddConstraint(&b, text, name);
    return b.graph().constraints.back();
  }
  double Residual(const Constraint& k) const {
    Eigen::VectorXd r;
    EvaluateResidual(*k.residual, b.graph().blocks, k.blocks, b.graph().nominal, &r, nullptr);
    return r.norm();
  }
};

TEST_CASE("lower: each relation becomes its kind, nominal and units resolved", "[dsl]") {
  const struct {
    const char* text;
    ConstraintKind kind;
    const char* kind_name;
    const char* described;
  } cases[] = {
      {"distance(a, b) == nominal", ConstraintKind::kDistanceEquality,
       "distance ==", "distance(a, b) == 0.5 m"},
      {"distance(a, b) == 50 cm", ConstraintKind::kDistanceEquality,
       "distance ==", "distance(a, b) == 0.5 m"},
      {"angle(b, a, c) == 90 deg", ConstraintKind::kExpression,
       "angle ==", "angle(b, a, c) == 90 deg"},
      {"dot(b - a, c - a) == 0", ConstraintKind::kExpression,
       "dot ==", "dot(b - a, c - a) == 0 m^2"},  // the zero takes the left-hand side's unit
      {"arm.tip == [1, 0, 0] m", ConstraintKind::kExpression,
       "expression ==", "arm.tip == [1, 0, 0] m"},
      {"root - a == [0, 0, 0]", ConstraintKind::kExpression,
       "expression ==", "arm.root - a == [0, 0, 0] m"},
      {"distance(a, leg.tip) >= 500 mm", ConstraintKind::kExpression,
       "distance >=", "distance(a, leg.tip) >= 0.5 m"},
      {"distance(a, c) <= nominal + 1 m", ConstraintKind::kExpression,
       "distance <=", "distance(a, c) <= 2 m"},
      {"angle(b, a, c) in [80 deg, 100 deg]", ConstraintKind::kExpression, "angle in",
       "angle(b, a, c) in [80 deg, 100 deg]"},
      {"parallel(arm.tip - a, b - a)", ConstraintKind::kRelation, "parallel",
       "parallel(arm.tip - a, b - a)"},
      {"rigid(a, b, c)", ConstraintKind::kRigid, "rigid", "rigid(a, b, c)"},
  };
  for (const auto& c : cases) {
    INFO(c.text);
    Model m;
    const Constraint& k = m.Add(c.text);
    CHECK(k.name == "k");
    CHECK(k.where.ToString() == "m.yaml:5:10");
    CHECK(k.kind == c.kind);
    CHECK(k.kind_name == c.kind_name);
    CHECK(m.b.graph().Describe(k) == c.described);
  }
  // `nominal` holds at the nominal geometry; an inequality's slack is its margin's root.
  Model m;
  CHECK(m.Residual(m.Add("distance(a, b) == nominal")) < 1e-15);
  const Constraint& k = m.Add("distance(a, c) <= 1.09 m", true, "k2");
  REQUIRE(k.slack_block >= 0);
  const Block& slack = m.b.graph().blocks[k.slack_block];
  CHECK(slack.name == "k2.slack");
  CHECK(m.b.graph().nominal.slacks[slack.index] == Approx(0.3));
  CHECK(m.Residual(k) < 1e-15);
}

TEST_CASE("lower: each refusal at the character it names", "[dsl]") {
  const struct {
    const char* text;
    const char* at;  // where in the text the error is (at '^' inside it); nullptr: at its start
    const char* message;
  } cases[] = {
      {"distance(a, b) = 1 m", "= 1", "syntax error in constraint: "},
      {"distance(a, bb) == 1 m", "bb", "unknown point 'bb' (did you mean 'b'?)"},
      {"distance(a, arm.tpi) == 1 m", "arm", "component 'arm' has no point 'tpi' (did you mean "},
      {"distance(a, aarm.tip) == 1 m", "aarm", "unknown component 'aarm' (did you mean 'arm'?)"},
      {"distance(a.x, b) == 1 m", "a.x",
       "'a' is a single-point component: write 'a' alone, it has no point 'x'"},
      {"distance(a, arm) == 1 m", "arm",
       "'arm' is a rigid component, not a point: name one of its points, e.g. arm.tip"},
      {"distance(a, tip) == 1 m", "tip",
       "point name 'tip' is ambiguous: it could be arm.tip, leg.tip; write component.point"},
      {"distance(a, b) == 12 mi", "mi", "unknown unit 'mi' (units: m, cm, mm, rad, deg)"},
      {"distanse(a, b) == 1 m", nullptr,
       "unknown function 'distanse' (did you mean 'distance'?); the functions are distance, "
       "angle, angle_between, dot, cross, norm"},
      {"norm(parallel(a, b)) == 1 m", "parallel",
       "parallel is a relation, not a value: write it alone as a whole constraint (usage: "},
      {"distance(a) == 1 m", nullptr,
       "distance takes 2 arguments, got 1 (usage: distance(a, b): two points)"},
      {"norm(a, 1 m) == 1 m", nullptr, "norm takes 1 argument, got 2"},
      {"distance(a, 2 m) == 1 m", "2 m",
       "argument 2 of distance must be a point or vector, got a scalar [m] (usage: "},
      {"distance(a, b) + 1 deg == 1 m", "+", "unit mismatch: [m] + [rad]"},
      {"nominal == distance(a, b)", nullptr,
       "'nominal' stands for the value of the left-hand side at the nominal geometry"},
      {"1 m == distance(a, b)", nullptr,
       "the left-hand side of a constraint must depend on the model's points"},
      {"distance(a, b) == 2", "2",
       "unit mismatch: the left-hand side is in [m] but the right-hand side is in [1]; a "
       "number without a unit is dimensionless, write e.g. '2 m'"},
      {"angle(b, a, c) >= 1.5", "1.5",
       "unit mismatch: the left-hand side is in [rad] but the "
       "right-hand side is in [1]; a number without a unit is "
       "dimensionless, write e.g. '1.5 deg'"},
      {"distance(a, b) == a", "== ^a",
       "the right-hand side is a vector but the left-hand side is a scalar"},
      {"a <= b", "<=", "an inequality compares scalars, not vectors"},
      {"a in [b, c]", "in", "a range bounds a scalar, not a vector"},
      {"distance(a, b) in [distance(a, c), 2 m]", "distance(a, c)",
       "the bounds of a range must be constants"},
      {"distance(a, b) in [1 m, distance(a, c)]", "distance(a, c)",
       "the bounds of a range must be constants"},
      {"distance(a, b) in [2 m, 1 m]", "2 m",
       "empty range: the lower bound 2 m is not below the upper bound 1 m"},
      {"distance(a, b) in [1 m, 2 deg]", "2 deg",
       "unit mismatch: the left-hand side is in [m] but the upper bound is in [rad]"},
      {"paralel(a - b, c - b)", nullptr,
       "unknown relation 'paralel' (did you mean 'parallel'?); the relations are parallel, "
       "perpendicular, coplanar, collinear, rigid, or use ==, <=, >=, in"},
      {"distance(a, b)", nullptr,
       "distance(...) is a value, not a constraint: compare it, e.g. 'distance(a, b) == "
       "nominal'"},
      {"coplanar(a, b, c)", nullptr,
       "coplanar takes at least 4 arguments, got 3 (usage: coplanar(a, b, c, d, ...): four or "
       "more points)"},
      {"parallel(a, b, c)", nullptr, "parallel takes 2 arguments, got 3 (usage: "},
      {"parallel(b - a, 1 m)", "1 m",
       "argument 2 of parallel must be a point or vector, got a "
       "scalar [m]"},
      {"parallel(a - a, b - a)", nullptr,
       "constraint 'k': parallel: argument 1 has zero length at the nominal geometry"},
      {"distance(a, b) == 0", nullptr,
       "constraint 'k': a distance or a norm required to be 0 holds only where it has no "
       "derivative"},
      {"a == [1 m, 0, 0] mm", "1 m",
       "element 1 already has a unit; a unit after the vector applies to plain numbers"},
  };
  for (const bool exact : {true, false}) {
    for (const auto& c : cases) {
      INFO(c.text << (exact ? "" : ", not verbatim"));
      Model m;
      const std::string text = c.text;
      std::string at = c.at ? c.at : "";
      const size_t caret = at.find('^');
      if (caret != std::string::npos) at.erase(caret, 1);
      const size_t found = text.find(at);
      REQUIRE(found != std::string::npos);
      const size_t offset = found + (caret == std::string::npos ? 0 : caret);
      try {
        m.Add(text, exact);
        FAIL("accepted");
      } catch (const InputError& e) {
        CHECK(e.where().ToString() ==
              fmt::format("m.yaml:5:{}", 10 + (exact ? static_cast<int>(offset) : 0)));
        CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
      }
      CHECK(m.b.graph().constraints.empty());
    }
  }
}

TEST_CASE("lower: constant quantities", "[dsl]") {
  const Model m;
  const Lowerer lower(m.b, TextOrigin{"m.yaml", 3, 12, true});
  CHECK(lower.LowerConstantScalar("12 mm", Quantity::Length(), "limit") == Approx(0.012));
  CHECK(lower.LowerConstantScalar("-90 deg", Quantity::Angle(), "limit") == Approx(-M_PI / 2));
  CHECK(lower.LowerConstantScalar("(1 + 2) * 0.5", Quantity{}, "factor") == 1.5);
  CHECK(lower.LowerConstantScalar("1 m / 2 rad", Quantity{1, -1}, "rate") == 0.5);
  const struct {
    const char* text;
    int column;
    const char* message;
  } cases[] = {
      {"12", 12, "invalid limit: expected [m], got [1]"},
      {"90 deg", 12, "invalid limit: expected [m], got [rad]"},
      {"2 * a", 16, "invalid limit: expected a number with a unit, e.g. '12 mm', found 'a'"},
      {"nominal", 12,
       "invalid limit: expected a number with a unit, e.g. '12 mm', found 'nominal'"},
      {"norm([1, 0, 0] m)", 12,
       "invalid limit: expected a number with a unit, e.g. '12 mm', "
       "found 'norm([1, 0, 0] m)'"},
      {"[1, 0, 0] m", 12, "invalid limit: expected a number with a unit, e.g. '12 mm'"},
      {"12 mm)", 17, "invalid limit: "},
      {"3 furlongs", 14, "unknown unit 'furlongs'"},
  };
  for (const auto& c : cases) {
    INFO(c.text);
    try {
      lower.LowerConstantScalar(c.text, Quantity::Length(), "limit");
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().ToString() == fmt::format("m.yaml:3:{}", c.column));
      CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
    }
  }
  CHECK(TextOrigin{"f", 2, 7, true}.At(4).ToString() == "f:2:11");
  CHECK(TextOrigin{"f", 2, 7, false}.At(4).ToString() == "f:2:7");
}

}  // namespace
}  // namespace cfuse
