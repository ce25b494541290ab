#include "cli/summary.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <ostream>

#include "cfuse/constraints/evaluate.h"

namespace cfuse::cli {

ModelSummary Summarize(const ConstraintGraph& graph) {
  ModelSummary s;
  for (const Component& c : graph.components) {
    (c.rigid ? s.rigid_components : s.point_components) += 1;
    s.feature_points += c.rigid ? static_cast<int>(c.points.size()) : 1;
    s.edges += static_cast<int>(c.edges.size());
    s.faces += static_cast<int>(c.faces.size());
  }
  for (const Block& b : graph.blocks) s.slacks += b.kind == BlockKind::kSlack ? 1 : 0;
  for (const Constraint& c : graph.constraints) {
    s.constraints_by_kind[c.kind_name] += 1;
    Eigen::VectorXd r;
    EvaluateResidual(*c.residual, graph.blocks, c.blocks, graph.nominal, &r, nullptr);
    const double worst = r.size() ? r.cwiseAbs().maxCoeff() : 0.0;
    if (!(worst <= kNominalTolerance)) {
      s.violations.push_back({c.name, graph.Describe(c), worst, c.where, {}, false});
    }
  }
  // Faces must be planar polygons for visibility to mean anything.
  for (const Component& c : graph.components) {
    for (const Face& f : c.faces) {
      Eigen::MatrixXd P(3, f.loop.size());
      for (size_t i = 0; i < f.loop.size(); ++i) P.col(i) = c.points[f.loop[i]].position;
      const Eigen::Vector3d centre = P.rowwise().mean();
      P.colwise() -= centre;
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(P, Eigen::ComputeFullU);
      const Eigen::Vector3d normal = svd.matrixU().col(2);
      const double off = (normal.transpose() * P).cwiseAbs().maxCoeff();
      const double extent = P.colwise().norm().maxCoeff();
      if (off > 1e-6 * extent) {
        s.warnings.emplace_back(f.where, fmt::format("face '{}' of '{}' is not planar: a point is "
                                                     "{:.3g} m off its best-fit plane",
                                                     f.name, c.name, off));
      }
    }
  }
  if (!graph.merged_joints.empty()) {
    std::string merged;
    for (const MergedJoint& m : graph.merged_joints) {
      merged += fmt::format("{}{} ({})", merged.empty() ? "" : ", ", m.name,
                            m.locked_at ? fmt::format("locked at {:.6g}", *m.locked_at) : "fixed");
    }
    s.notes.push_back(
        fmt::format("joints merged into their parents' components, so they "
                    "add no state: {}",
                    merged));
  }
  for (const Joint& j : graph.joints) {
    if (j.limits && j.limit_constraint < 0) {
      s.notes.push_back(
          fmt::format("joint '{}': its limits span a full turn or more, so they do "
                      "not restrict it",
                      j.name));
    }
  }
  s.dof = AnalyzeDof(graph, graph.nominal);
  for (Violation& v : s.violations) {
    const bool redundant = std::any_of(s.dof.redundant.begin(), s.dof.redundant.end(),
                                       [&](const auto& r) { return r.first == v.constraint; });
    if (!redundant) continue;
    v.repeats_hold = true;
    for (int k : ImplyingConstraints(graph, graph.nominal, graph.FindConstraint(v.constraint))) {
      const Constraint& c = graph.constraints[k];
      v.repeats.emplace_back(c.name, graph.Describe(c));
      v.repeats_hold &= std::none_of(s.violations.begin(), s.violations.end(),
                                     [&](const Violation& w) { return w.constraint == c.name; });
    }
  }
  const long locked = std::count_if(graph.merged_joints.begin(), graph.merged_joints.end(),
                                    [](const MergedJoint& m) { return m.locked_at.has_value(); });
  if (locked > 0 && s.dof.computed) {
    // URDF's count, 6 + movable - mimic, takes a revolute or prismatic joint as movable even when
    // its limits are equal; say what that count would be.
    s.notes.push_back(
        fmt::format("{} joint{} locked by equal limits (lower = upper) add{} no DOF; "
                    "counted as movable, the DOF would be {}",
                    locked, locked == 1 ? "" : "s", locked == 1 ? "s" : "", s.dof.dof + locked));
  }
  return s;
}

void PrintSummary(const ConstraintGraph& graph, const ModelSummary& s, std::ostream& out) {
  out << fmt::format("model: {} ({})\n", graph.name, graph.source);
  out << fmt::format("components: {} ({} rigid, {} single-point)\n", graph.components.size(),
                     s.rigid_components, s.point_components);
  out << fmt::format("points: {}   edges: {}   faces: {}\n", s.feature_points, s.edges, s.faces);
  std::string joints;
  for (const Joint& j : graph.joints) {
    joints += fmt::format("{}{} ({})", joints.empty() ? "" : ", ", j.name, JointTypeName(j.type));
  }
  out << fmt::format("joints: {}{}\n", graph.joints.size(), joints.empty() ? "" : ": " + joints);
  std::string kinds;
  for (const auto& [kind, n] : s.constraints_by_kind) {
    kinds += fmt::format("{}{} {}", kinds.empty() ? "" : ", ", n, kind);
  }
  out << fmt::format("constraints: {}{}\n", graph.constraints.size(),
                     kinds.empty() ? "" : " (" + kinds + ")");
  out << fmt::format("equations: {}   slack variables: {}\n", s.dof.equations, s.slacks);
  if (!s.dof.computed) {
    out << fmt::format("state dimension: {}\n", s.dof.state_dim);
    out << fmt::format(
        "DOF: not computed (the dense rank analysis is limited to a state "
        "dimension of {})\n",
        kMaxDofStateDim);
  } else {
    out << fmt::format("state dimension: {}   constraint Jacobian rank: {}\n", s.dof.state_dim,
                       s.dof.rank);
    out << fmt::format("DOF: {} ({} rigid-body + {} internal)\n", s.dof.dof, s.dof.rigid_body,
                       s.dof.internal);
  }
  for (const Constraint& c : graph.constraints) {
    if (c.redundant_rows == 0) continue;
    const int written = c.residual->dimension() + c.redundant_rows;
    out << fmt::format(
        "note: constraint '{}' ({}) is redundant in {} of its {} equations, which the "
        "constraints before it imply at the nominal geometry: the other {} are fused\n",
        c.name, graph.Describe(c), c.redundant_rows, written, c.residual->dimension());
  }
  for (const auto& [name, rows] : s.dof.redundant) {
    const Constraint& c = graph.constraints[graph.FindConstraint(name)];
    out << fmt::format("note: constraint '{}' ({}) is redundant in {} of its {} equation{}\n", name,
                       graph.Describe(c), rows, c.residual->dimension(),
                       c.residual->dimension() == 1 ? "" : "s");
  }
  for (const std::string& note : s.notes) out << "note: " << note << "\n";
  for (const auto& [where, message] : s.warnings) {
    out << fmt::format("{}: warning: {}\n", where.ToString(), message);
  }
  if (!s.violations.empty()) {
    out << "note: the nominal geometry violates constraints (below), so the DOF above were "
           "computed away from the model's constraint surface and may be wrong\n";
  }
  for (const Violation& v : s.violations) {
    std::string repeats;
    for (const auto& [name, formula] : v.repeats) {
      repeats += fmt::format("{}'{}' ({})", repeats.empty() ? "" : ", ", name, formula);
    }
    out << fmt::format(
        "{}: warning: constraint '{}' ({}) is violated by the nominal geometry "
        "(largest residual {:.3g}){}\n",
        v.where.ToString(), v.constraint, v.formula, v.residual,
        repeats.empty() ? ""
        : v.repeats_hold
            ? fmt::format("; it restates what {} fix{}, which hold{} there: they contradict "
                          "each other",
                          repeats, v.repeats.size() == 1 ? "es" : "", v.repeats.size() == 1 ? "s" : "")
            : fmt::format("; it restates what {} fix{}", repeats, v.repeats.size() == 1 ? "es" : ""));
  }
}

nlohmann::json SummaryJson(const ConstraintGraph& graph, const ModelSummary& s) {
  nlohmann::json j;
  j["model"] = graph.name;
  j["source"] = graph.source;
  j["components"] = {{"total", graph.components.size()},
                     {"rigid", s.rigid_components},
                     {"single_point", s.point_components}};
  j["points"] = s.feature_points;
  j["edges"] = s.edges;
  j["faces"] = s.faces;
  j["joints"] = nlohmann::json::array();
  for (const Joint& jt : graph.joints) {
    j["joints"].push_back({{"name", jt.name}, {"type", JointTypeName(jt.type)}});
  }
  j["constraints"] = {{"total", graph.constraints.size()}, {"by_kind", s.constraints_by_kind}};
  j["equations"] = s.dof.equations;
  j["slack_variables"] = s.slacks;
  j["state_dimension"] = s.dof.state_dim;
  if (s.dof.computed) {
    j["rank"] = s.dof.rank;
    j["dof"] = {
        {"total", s.dof.dof}, {"rigid_body", s.dof.rigid_body}, {"internal", s.dof.internal}};
  } else {
    j["rank"] = nullptr;
    j["dof"] = nullptr;
  }
  j["redundant"] = nlohmann::json::array();
  for (const auto& [name, rows] : s.dof.redundant)
    j["redundant"].push_back({{"constraint", name}, {"rows", rows}});
  j["violations"] = nlohmann::json::array();
  for (const Violation& v : s.violations) {
    j["violations"].push_back({{"constraint", v.constraint},
                               {"formula", v.formula},
                               {"residual", v.residual},
                               {"where", v.where.ToString()},
                               {"repeats", nlohmann::json::array()}});
    for (const auto& [name, formula] : v.repeats) {
      j["violations"].back()["repeats"].push_back(name);
    }
  }
  j["warnings"] = nlohmann::json::array();
  for (const auto& [where, message] : s.warnings) {
    j["warnings"].push_back({{"where", where.ToString()}, {"message", message}});
  }
  j["notes"] = s.notes;
  return j;
}

}  // namespace cfuse::cli
