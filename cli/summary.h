// What `cfuse check` reports about a model: its parts, constraints by kind, degrees of freedom
// and the constraints the nominal geometry violates.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cfuse/constraints/dof.h"
#include "cfuse/constraints/graph.h"

namespace cfuse::cli {

struct Violation {
  std::string constraint;
  std::string formula;
  double residual = 0;  // largest |r_i| at the nominal geometry
  SourceLocation where;
  // The constraints before it that it repeats in part (cfuse/constraints/dof.h,
  // ImplyingConstraints), with their formulas: those it contradicts where they hold.
  std::vector<std::pair<std::string, std::string>> repeats;
  bool repeats_hold = false;  // every one of them holds at the nominal geometry
};

struct ModelSummary {
  int point_components = 0, rigid_components = 0, feature_points = 0, edges = 0, faces = 0;
  std::map<std::string, int> constraints_by_kind;
  int slacks = 0;
  DofReport dof;
  std::vector<Violation> violations;
  std::vector<std::pair<SourceLocation, std::string>> warnings;  // other problems, located
  std::vector<std::string> notes;
};

// Residuals above this at the nominal geometry are reported as violations.
inline constexpr double kNominalTolerance = 1e-9;

ModelSummary Summarize(const ConstraintGraph& graph);
void PrintSummary(const ConstraintGraph& graph, const ModelSummary& s, std::ostream& out);
nlohmann::json SummaryJson(const ConstraintGraph& graph, const ModelSummary& s);

}  // namespace cfuse::cli
