// The constraint graph in Graphviz's dot language: components are nodes (boxes for rigid
// components, ellipses for single points), joints are labelled directed edges parent -> child,
// and every other constraint is a small hyper-node joined to the components it touches,
// labelled with its name and formula.
#pragma once

#include <ostream>

#include "cfuse/constraints/graph.h"

namespace cfuse {

void WriteDot(const ConstraintGraph& graph, std::ostream& out);

}  // namespace cfuse
