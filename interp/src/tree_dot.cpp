// The interpretation tree drawn for Graphviz: per level its best candidates and the choice.
#include <fmt/format.h>

#include "cfuse/interp/interpretation.h"

namespace cfuse {

std::string TreeDot(const ConstraintGraph& graph, const Interpretation& in) {
  std::string dot = fmt::format(
      "digraph interpretation {{\n  label=\"interpretation tree of '{}': per level the 3 best "
      "candidates (δ), the chosen one bold; constraints fused at each level\";\n  rankdir=TB;\n"
      "  node [shape=box, fontname=\"Helvetica\", fontsize=10];\n  root [label=\"start\"];\n",
      graph.name);
  std::string parent = "root";
  for (size_t l = 0; l < in.trace.size(); ++l) {
    const TraceLevel& t = in.trace[l];
    std::string constraints;
    for (int k : t.constraints) {
      constraints += (constraints.empty() ? "" : ", ") + graph.constraints[k].name;
    }
    const std::string point = ModelPointName(graph, t.component, t.feature);
    dot += fmt::format(
        "  subgraph level{} {{ rank=same;\n    info{} [shape=plaintext, label=\"level {}: "
        "{}{}\"];\n",
        l + 1, l + 1, l + 1, point, constraints.empty() ? "" : "\\nfused: " + constraints);
    std::string chosen_node;
    bool chosen_listed = false;
    for (size_t i = 0; i < t.best.size(); ++i) {
      const auto& [m, delta] = t.best[i];
      const bool chosen = m == t.chosen;
      const std::string id = fmt::format("n{}_{}", l + 1, i);
      dot += fmt::format("    {} [label=\"{} ← m{}\\nδ = {:.2f}\"{}];\n", id, point, m, delta,
                         chosen ? ", style=bold, penwidth=2" : ", color=gray50, fontcolor=gray40");
      if (chosen) {
        chosen_node = id;
        chosen_listed = true;
      }
    }
    if (!chosen_listed) {
      chosen_node = fmt::format("n{}_c", l + 1);
      dot += fmt::format(
          "    {} [label=\"{}\", style=bold, penwidth=2];\n", chosen_node,
          t.chosen < 0 ? point + " occluded (null)" : fmt::format("{} ← m{}", point, t.chosen));
    }
    dot += "  }\n";
    for (size_t i = 0; i < t.best.size(); ++i) {
      dot += fmt::format("  {} -> n{}_{};\n", parent, l + 1, i);
    }
    if (!chosen_listed) dot += fmt::format("  {} -> {};\n", parent, chosen_node);
    parent = chosen_node;
  }
  dot += "}\n";
  return dot;
}

}  // namespace cfuse
