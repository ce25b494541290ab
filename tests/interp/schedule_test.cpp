// The fusion order of Hel-Or & Werman §6/§7: the invariants on the lamp and every example, and
// hand-checked orders on small graphs.
#include "cfuse/interp/schedule.h"

#include <catch2/catch.hpp>
#include <fstream>
#include <iterator>

#include "cfuse/dsl/model_loader.h"
#include "test_util.h"

namespace cfuse {
namespace {

ConstraintGraph Model(const std::string& text) {
  return LoadModelFromString(text, "model.yaml", ".");
}

// The names matched, level by level, and the constraints fused before each.
std::vector<std::string> Matches(const ConstraintGraph& g, const FusionPlan& plan) {
  std::vector<std::string> out;
  for (const PlanLevel& l : plan.levels) out.push_back(ModelPointName(g, l.component, l.feature));
  return out;
}
std::vector<std::string> Fused(const ConstraintGraph& g, const std::vector<int>& constraints) {
  std::vector<std::string> out;
  for (int k : constraints) out.push_back(g.constraints[k].name);
  return out;
}

// §6's invariants, level by level:
//  - every constraint is fused exactly once and every model point matched exactly once;
//  - a constraint all of whose components are matched is fused before the next match;
//  - a component is matched after some fused constraint links it to matched components,
//    whenever a constraint linking it to them exists.
void CheckInvariants(const ConstraintGraph& g, const FusionPlan& plan) {
  std::vector<int> fused_count(g.constraints.size(), 0);
  std::vector<bool> matched(g.components.size(), false), fused(g.constraints.size(), false);
  size_t points = 0;
  for (const Component& c : g.components) points += c.rigid ? c.points.size() : 1;
  REQUIRE(plan.levels.size() == points);
  for (size_t i = 0; i < plan.levels.size(); ++i) {
    const PlanLevel& l = plan.levels[i];
    INFO("level " << i + 1 << ": " << ModelPointName(g, l.component, l.feature));
    for (int k : l.constraints) {
      ++fused_count[k];
      fused[k] = true;
    }
    const bool first_of_component = !matched[l.component];
    if (first_of_component && i > 0) {
      // Linked to matched components by some constraint? Then a fused one links it.
      bool linkable = false, linked = false;
      for (size_t k = 0; k < g.constraints.size(); ++k) {
        const std::vector<int> comps = ConstraintComponents(g, g.constraints[k]);
        const bool touches = std::find(comps.begin(), comps.end(), l.component) != comps.end();
        const bool touches_matched =
            std::any_of(comps.begin(), comps.end(), [&](int c) { return matched[c]; });
        if (touches && touches_matched) {
          linkable = true;
          linked = linked || fused[k];
        }
      }
      CHECK((!linkable || linked));
    }
    // At a component's first level, every constraint on components matched before it has
    // been fused (a rigid component's levels are matched together, §7).
    for (size_t k = 0; first_of_component && k < g.constraints.size(); ++k) {
      const std::vector<int> comps = ConstraintComponents(g, g.constraints[k]);
      if (std::all_of(comps.begin(), comps.end(), [&](int c) { return matched[c]; })) {
        INFO("constraint " << g.constraints[k].name);
        CHECK(fused[k]);
      }
    }
    matched[l.component] = true;
  }
  for (int k : plan.trailing) ++fused_count[k];
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    INFO("constraint " << g.constraints[k].name);
    CHECK(fused_count[k] == 1);
  }
}

TEST_CASE("plan: the lamp and every example keep §6's invariants", "[interp]") {
  for (const char* file : {"examples/lamp.yaml", "examples/hinged-box.yaml",
                           "examples/scissors.yaml", "examples/planar-arm.yaml"}) {
    INFO(file);
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    for (bool image : {false, true}) CheckInvariants(g, PlanFusion(g, image));
  }
}

TEST_CASE("plan: the lamp starts from its base triangle, a pose in closed form", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  const FusionPlan plan = PlanFusion(g);
  REQUIRE(plan.seed_levels == 3);
  CHECK_FALSE(plan.seed_is_rigid_component);
  // p1, p3 and p6 are pairwise held by distances and span the largest smallest side.
  const std::vector<std::string> m = Matches(g, plan);
  CHECK(std::vector<std::string>(m.begin(), m.begin() + 3) ==
        std::vector<std::string>{"p1", "p3", "p6"});
  CHECK(FormatPlan(g, plan).find("seed: p1, p3, p6") != std::string::npos);
}

TEST_CASE("plan: a model with no rigid triple says it has no seed", "[interp]") {
  // Held only by a perpendicular and a coplanarity: no three points rigid.
  const ConstraintGraph g = Model(R"(points: {a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0], d: [1, 1, 0]}
constraints:
  - perpendicular(b - a, c - a)
  - coplanar(a, b, c, d)
)");
  const FusionPlan plan = PlanFusion(g);
  CHECK(plan.seed_levels == 0);
  const std::string text = FormatPlan(g, plan);
  CHECK(text.find("warning: no seed: no three points are held rigid") != std::string::npos);
  CHECK(text.find("seed: ") == text.find("no seed: ") + 3);  // no seed line besides
}

// Two sides and the right angle between them hold a triangle rigid although no distance
// constraint joins its other two corners: the seed comes from the constraint Jacobian (the
// third side's length cannot change along any direction the constraints leave free), and a
// corner held by coplanarity and two distances joins it.
TEST_CASE("plan: a triangle made rigid by a right angle is a seed", "[interp]") {
  std::ifstream file(testing::SourcePath("tests/data/models/right-triangle.yaml"));
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const ConstraintGraph g = Model(text);
  const std::vector<std::array<int, 3>> triangles = RigidTriangles(g);
  REQUIRE(!triangles.empty());
  const FusionPlan plan = PlanFusion(g);
  CHECK(plan.seed_levels == 3);
  CHECK(FormatPlan(g, plan).find("no seed") == std::string::npos);
  // Without the right angle nothing but the sides is rigid: no triangle.
  std::string loose = text;
  loose.replace(loose.find("  - perpendicular(b - a, c - a)\n"), 32, "");
  REQUIRE(loose.find("perpendicular") == std::string::npos);
  CHECK(RigidTriangles(Model(loose)).empty());
}

TEST_CASE("plan: hand-checked orders on small graphs", "[interp]") {
  SECTION("a chain of points: each next point after the distance that reaches it") {
    const ConstraintGraph g = Model(R"(
name: chain
points: {a: [0, 0, 0], b: [1, 0, 0], c: [2, 0, 0], d: [3, 0.5, 0]}
constraints:
  - name: cd
    expr: distance(c, d) == nominal
  - name: ab
    expr: distance(a, b) == nominal
  - name: bc
    expr: distance(b, c) == nominal
)");
    const FusionPlan plan = PlanFusion(g);
    CHECK(plan.seed_levels == 0);  // no rigid triangle
    // (d) fuses the first constraint, cd; (b) matches c and d; (c) bc; b; (c) ab; a.
    CHECK(Matches(g, plan) == std::vector<std::string>{"c", "d", "b", "a"});
    CHECK(Fused(g, plan.levels[0].constraints) == std::vector<std::string>{"cd"});
    CHECK(Fused(g, plan.levels[1].constraints).empty());
    CHECK(Fused(g, plan.levels[2].constraints) == std::vector<std::string>{"bc"});
    CHECK(Fused(g, plan.levels[3].constraints) == std::vector<std::string>{"ab"});
    CHECK(plan.trailing.empty());
  }
  SECTION("a triangle first, a point held by two distances, a free point last") {
    const ConstraintGraph g = Model(R"(
name: tri
points: {x: [5, 5, 5], a: [0, 0, 0], b: [1, 0, 0], c: [0, 1, 0], e: [1, 1, 1]}
constraints:
  - name: ae
    expr: distance(a, e) == nominal
  - name: ab
    expr: distance(a, b) == nominal
  - name: bc
    expr: distance(b, c) == nominal
  - name: ca
    expr: distance(c, a) == nominal
  - name: be
    expr: distance(b, e) == nominal
)");
    const FusionPlan plan = PlanFusion(g);
    REQUIRE(plan.seed_levels == 3);
    // (d) at the start: ab, the first constraint within the triangle; (b) a, b; (c) prefers
    // the constraint reaching the triangle's c (bc, first in model order of ca and bc) and
    // (c') fuses ca with it; c; (c) ae, which reaches e, with be (c'); e; x, linked to
    // nothing, last.
    CHECK(Matches(g, plan) == std::vector<std::string>{"a", "b", "c", "e", "x"});
    CHECK(Fused(g, plan.levels[0].constraints) == std::vector<std::string>{"ab"});
    CHECK(Fused(g, plan.levels[2].constraints) == std::vector<std::string>{"bc", "ca"});
    CHECK(Fused(g, plan.levels[3].constraints) == std::vector<std::string>{"ae", "be"});
    CHECK(Fused(g, plan.levels[4].constraints).empty());
    CheckInvariants(g, plan);
  }
  SECTION("one rigid component and no constraints: its seed features first") {
    const ConstraintGraph g = Model(R"(
name: block
components:
  b:
    points: {o: [0, 0, 0], near: [0.01, 0, 0], x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1]}
)");
    const FusionPlan plan3 = PlanFusion(g, false), plan2 = PlanFusion(g, true);
    CHECK(plan3.seed_levels == 3);
    CHECK(plan3.seed_is_rigid_component);
    CHECK(plan2.seed_levels == 4);
    // The largest triangle is x, y, z; for image data the farthest from its plane is o.
    CHECK(Matches(g, plan3) == std::vector<std::string>{"b.x", "b.y", "b.z", "b.o", "b.near"});
    CHECK(Matches(g, plan2) == std::vector<std::string>{"b.x", "b.y", "b.z", "b.o", "b.near"});
  }
}

}  // namespace
}  // namespace cfuse
