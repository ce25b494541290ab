// TreeDot: the interpretation tree in Graphviz's language, each level's best candidates and the
// choice, checked on a trace written by hand.
#include <catch2/catch.hpp>
#include <string>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/interpretation.h"
#include "test_util.h"

namespace cfuse {
namespace {

bool Has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST_CASE("tree dot: each level's candidates, the choice bold, the path through the choices",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("tests/data/models/right-triangle.yaml"));
  const int a = g.FindComponent("a"), b = g.FindComponent("b"), c = g.FindComponent("c");
  Interpretation in;
  // Level 1: `a` matched to m4, the best of three candidates, after two constraints.
  in.trace.push_back({{0, 1}, a, -1, 4, {{4, 0.5}, {2, 3.25}, {7, 9.125}}});
  // Level 2: `b` occluded, its one candidate not taken.
  in.trace.push_back({{}, b, -1, -1, {{5, 12.0}}});
  // Level 3: `c` matched to m9, which is not among its best listed.
  in.trace.push_back({{2}, c, -1, 9, {{1, 0.25}}});
  const std::string dot = TreeDot(g, in);
  INFO(dot);
  CHECK(dot.rfind("digraph interpretation {\n  label=\"interpretation tree of 'right triangle'",
                  0) == 0);
  const std::string fused =
      "\\nfused: " + g.constraints[0].name + ", " + g.constraints[1].name + "\"];";
  CHECK(Has(dot, "info1 [shape=plaintext, label=\"level 1: a" + fused));
  CHECK(Has(dot, "info2 [shape=plaintext, label=\"level 2: b\"];"));
  CHECK(Has(dot, "n1_0 [label=\"a ← m4\\nδ = 0.50\", style=bold, penwidth=2];"));
  CHECK(Has(dot, "n1_1 [label=\"a ← m2\\nδ = 3.25\", color=gray50, fontcolor=gray40];"));
  CHECK(Has(dot, "n1_2 [label=\"a ← m7\\nδ = 9.12\""));  // two decimals
  // The null branch chosen: a node of its own, the path goes on from it.
  CHECK(Has(dot, "n2_c [label=\"b occluded (null)\", style=bold, penwidth=2];"));
  CHECK(Has(dot, "n3_c [label=\"c ← m9\", style=bold, penwidth=2];"));
  for (const char* edge : {"root -> n1_0;", "root -> n1_1;", "root -> n1_2;", "n1_0 -> n2_0;",
                           "n1_0 -> n2_c;", "n2_c -> n3_0;", "n2_c -> n3_c;"}) {
    CHECK(Has(dot, std::string("  ") + edge + "\n"));
  }
  // The chosen candidates are the path: nothing hangs below an unchosen one.
  CHECK_FALSE(Has(dot, "n1_1 ->"));
  CHECK(dot.substr(dot.size() - 2) == "}\n");
  long open = 0;
  for (char ch : dot) open += ch == '{' ? 1 : ch == '}' ? -1 : 0;
  CHECK(open == 0);
}

TEST_CASE("tree dot: an empty trace is the root alone", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("tests/data/models/right-triangle.yaml"));
  const std::string dot = TreeDot(g, Interpretation{});
  CHECK(Has(dot, "root [label=\"start\"];\n}\n"));
  CHECK_FALSE(Has(dot, "->"));
}

}  // namespace
}  // namespace cfuse
