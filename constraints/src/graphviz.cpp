#include "cfuse/constraints/graphviz.h"

#include <fmt/format.h>

#include <set>

#include "cfuse/constraints/expr.h"
#include "cfuse/constraints/joint_model.h"

namespace cfuse {
namespace {

// A dot double-quoted string.
std::string Quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

}  // namespace

void WriteDot(const ConstraintGraph& graph, std::ostream& out) {
  out << "graph " << Quote(graph.name.empty() ? "model" : graph.name) << " {\n";
  out << "  graph [overlap=false, fontname=\"Helvetica\", label="
      << Quote(fmt::format("{}: {} components, {} constraints", graph.name, graph.components.size(),
                           graph.constraints.size()))
      << "];\n";
  out << "  node [fontname=\"Helvetica\", fontsize=11];\n  edge [fontname=\"Helvetica\", "
         "fontsize=9];\n";
  std::vector<int> component_of_block(graph.blocks.size(), -1);
  for (size_t i = 0; i < graph.components.size(); ++i) {
    const Component& c = graph.components[i];
    component_of_block[c.block] = static_cast<int>(i);
    const std::string label =
        c.rigid ? fmt::format("{}\n{} points", c.name, c.points.size()) : c.name;
    out << fmt::format("  c{} [label={}, shape={}];\n", i, Quote(label),
                       c.rigid ? "box" : "ellipse");
  }
  std::set<int> joint_constraints;
  for (const Joint& j : graph.joints) {
    joint_constraints.insert(j.constraint);
    std::string label = fmt::format("{}\n{}", j.name, JointTypeName(j.type));
    if (j.limit_constraint >= 0) joint_constraints.insert(j.limit_constraint);
    if (j.limits) {
      const Quantity q = ModelOf(j.type).VariableIsLength() ? Quantity::Length() : Quantity::Angle();
      label += fmt::format("\nlimits [{}, {}]", FormatQuantity(j.limits->first, q),
                           FormatQuantity(j.limits->second, q));
    }
    out << fmt::format("  c{} -- c{} [label={}, dir=forward, penwidth=2];\n", j.parent, j.child,
                       Quote(label));
  }
  for (size_t k = 0; k < graph.constraints.size(); ++k) {
    if (joint_constraints.count(static_cast<int>(k))) continue;
    const Constraint& c = graph.constraints[k];
    out << fmt::format(
        "  k{} [label={}, shape=note, fontsize=9, style=filled, "
        "fillcolor=\"#f3f3f3\"];\n",
        k, Quote(c.name + "\n" + graph.Describe(c)));
    std::set<int> touched;
    for (int b : c.blocks) {
      if (component_of_block[b] >= 0) touched.insert(component_of_block[b]);
    }
    for (int comp : touched) out << fmt::format("  k{} -- c{};\n", k, comp);
  }
  out << "}\n";
}

}  // namespace cfuse
