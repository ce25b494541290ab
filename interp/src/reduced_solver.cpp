#include "reduced_solver.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/so3.h"
#include "cfuse/kernel/triangular.h"
#include "kinematic_forest.h"

namespace cfuse::internal {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

// The forest and the parameters each pose depends on: what stays fixed over a solve.
struct Reduction {
  Forest forest;
  std::vector<std::vector<Influence>> influence;
  // Per block: the parameters its tangent coordinates depend on, ascending (a slack's: those
  // of its inequality's other blocks, filled per solve).
  std::vector<std::vector<int>> block_parameters;
};

// Why the graph's joints cannot be eliminated, or "" with the forest's structure in `forest`
// (if given).
std::string Structure(const ConstraintGraph& graph, Forest* forest) {
  if (graph.joints.empty()) return "the model has no joints";
  if (std::string why = BuildForest(graph, ForestRules::kJointsFirst, forest); !why.empty()) {
    return why;
  }
  for (const Block& b : graph.blocks) {
    if (b.kind == BlockKind::kPoint) return "a point block outside the components";
  }
  return "";
}

// Why the factors' slacks cannot be eliminated (each must belong to one inequality of one row,
// which it is eliminated with), or "".
std::string SlackUse(const ConstraintGraph& graph, const std::vector<Factor>& factors) {
  std::vector<int> uses(graph.blocks.size(), 0);
  for (const Factor& f : factors) {
    for (int b : f.blocks) {
      if (b < 0 || b >= static_cast<int>(graph.blocks.size())) return "a factor off the graph";
      if (graph.blocks[b].kind != BlockKind::kSlack) continue;
      if (!f.is_constraint() || f.residual->dimension() != 1 || ++uses[b] > 1) {
        return "a slack outside a single one-row inequality";
      }
    }
  }
  return "";
}

// The parameters of a forest of the graph, as LayoutParameters lays them out.
int ParameterCount(const ConstraintGraph& graph, const Forest& f) {
  int count = 0;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (f.parent_joint[c] < 0 && !f.fixed[c]) count += 6;
  }
  for (const Joint& j : graph.joints) {
    if (!j.mimic) count += ModelOf(j.type).ParameterCount();
  }
  return count;
}

// Structure's answer, and the reduction in `out` (each parameter's prior_sigma `length` for a
// length, 1 for an angle: its column scale).
std::string Reduce(const ConstraintGraph& graph, Reduction* out, double length = 1.0) {
  Reduction r;
  if (std::string why = Structure(graph, &r.forest); !why.empty()) return why;
  LayoutParameters(graph, length, 1.0, &r.forest, false);  // not a prior: the poses' are
  r.influence = Influences(graph, r.forest);
  r.block_parameters.resize(graph.blocks.size());
  for (size_t c = 0; c < graph.components.size(); ++c) {
    std::vector<int>& p = r.block_parameters[graph.components[c].block];
    for (const Influence& in : r.influence[c]) p.push_back(in.parameter);
    std::sort(p.begin(), p.end());
    p.erase(std::unique(p.begin(), p.end()), p.end());
  }
  *out = std::move(r);
  return "";
}

// W = L⁻¹ (R = L Lᵀ) by R's diagonal blocks: each block's first row and size, and its W
// (lower triangular, column-major) at `offset` in one array, so that a factor's whitening costs
// no allocation per marker.
struct WhiteningBlock {
  int first, size, offset;
};
struct Whitener {
  std::vector<WhiteningBlock> blocks;
  std::vector<double> values;
};

// R's whitening in `out`; false when R is not positive definite.
bool Whitening(const Eigen::MatrixXd& R, Whitener* out) {
  out->blocks.clear();
  out->values.clear();
  const Eigen::Index n = R.rows();
  out->blocks.reserve(static_cast<size_t>(n));
  out->values.reserve(static_cast<size_t>(3 * n));  // a 3D marker's blocks, without regrowing
  for (Eigen::Index first = 0; first < n;) {
    Eigen::Index end = first + 1;  // grown until nothing outside [first, end) couples to it
    for (Eigen::Index i = first; i < end; ++i) {
      for (Eigen::Index j = n - 1; j >= end; --j) {
        if (R(i, j) != 0 || R(j, i) != 0) {
          end = j + 1;
          break;
        }
      }
    }
    const auto size = static_cast<int>(end - first);
    const auto offset = static_cast<int>(out->values.size());
    out->blocks.push_back({static_cast<int>(first), size, offset});
    out->values.resize(out->values.size() + static_cast<size_t>(size) * size);
    double* w = out->values.data() + offset;
    if (size == 1) {  // isotropic noise: every row its own
      if (!(R(first, first) > 0)) return false;
      w[0] = 1 / std::sqrt(R(first, first));
    } else if (size == 3) {  // a 3D marker's, at its fixed size
      const Eigen::LLT<Eigen::Matrix3d> llt(R.block<3, 3>(first, first));
      if (llt.info() != Eigen::Success) return false;
      const Eigen::Matrix3d L = llt.matrixL();
      Eigen::Map<Eigen::Matrix3d> W(w);
      W = L.inverse();
    } else {
      const Eigen::LLT<Eigen::MatrixXd> llt(R.block(first, first, size, size));
      if (llt.info() != Eigen::Success) return false;
      Eigen::Map<Eigen::MatrixXd> W(w, size, size);
      W = LowerTriangularInverse(llt.matrixLLT());
    }
    first = end;
  }
  return true;
}

// Per factor: how it enters the reduced problem.
struct FactorMap {
  bool held = false;  // a constraint the forest holds by construction
  // An inequality's one row with its slack λ, eliminated together: the row's slot of λ, or
  // -1. Linearised, c + a Δz + a_λ Δλ = 0 gives Δλ = -(c + a Δz) / a_λ, and λ's prior
  // becomes a measurement of z; the last linearisation is kept for the step and for λ's
  // covariance.
  int slack_slot = -1;
  double c = 0, a_lambda = 0;
  Eigen::RowVectorXd a;
  // A forest joint's limit, read at the joint variable (JointLimitResidual::AtValue) rather
  // than differentiated through both poses: its joint, or -1.
  int limit_joint = -1;
  const JointLimitResidual* limit = nullptr;
  std::vector<int> parameters;  // those its blocks (but an eliminated slack) depend on
  std::vector<int> first_column;
  // Measurements: W = Lw⁻¹ (R = Lw Lwᵀ) by R's diagonal blocks (a stacked factor's markers,
  // each its own).
  Whitener whiten;
  bool whitened = true;  // false: R not positive definite
};

// dx/dz over the factor's pose blocks: rows its Jacobian's columns, columns its parameters.
void FactorTangent(const ConstraintGraph& graph, const Factor& factor, const FactorMap& map,
                   const Eigen::MatrixXd& G, Eigen::MatrixXd* Tf) {
  Tf->setZero(factor.residual->arity(), static_cast<Eigen::Index>(map.parameters.size()));
  for (size_t s = 0; s < factor.blocks.size(); ++s) {
    const Block& b = graph.blocks[factor.blocks[s]];
    if (b.kind != BlockKind::kPose) continue;
    for (size_t k = 0; k < map.parameters.size(); ++k) {
      Tf->block<6, 1>(map.first_column[s], static_cast<Eigen::Index>(k)) =
          G.block<6, 1>(b.tangent_offset, map.parameters[k]);
    }
  }
}

// A graph constraint as Prepare looks it up.
struct ConstraintUse {
  const ResidualFunction* residual = nullptr;
  bool held = false;     // by the forest's construction
  int limit_joint = -1;  // the forest joint whose limit it is
};

// What stays fixed over a solve and its fit analysis: the reduction and each factor's map.
struct Problem {
  Reduction red;
  std::vector<FactorMap> maps;
  int constraint_rows = 0;  // rows kept as rows (neither held nor eliminated with a slack)
  int eliminated_slacks = 0;
};

// The problem of `factors` on the graph's forest, its parameters' prior_sigma `length` for a
// length and 1 for an angle (the fit analysis's column scale); or ReducedUnsupported's answer.
std::string Prepare(const ConstraintGraph& graph, const std::vector<Factor>& factors, double length,
                    Problem* out) {
  Problem& p = *out;
  if (std::string why = Reduce(graph, &p.red, length); !why.empty()) return why;
  if (std::string why = SlackUse(graph, factors); !why.empty()) return why;
  const Forest& forest = p.red.forest;
  // The graph's constraints by their residual, which Solve's factors share: whether the forest
  // holds each, and the forest joint whose limit it is (read at the joint variable).
  std::vector<ConstraintUse> uses(graph.constraints.size());
  for (size_t k = 0; k < graph.constraints.size(); ++k) {
    uses[k] = {graph.constraints[k].residual.get(), static_cast<bool>(forest.held[k]), -1};
  }
  for (size_t j = 0; j < graph.joints.size(); ++j) {
    const int k = graph.joints[j].limit_constraint;
    if (k >= 0 && forest.joint_parameter[forest.leader[j]] >= 0) {
      uses[k].limit_joint = static_cast<int>(j);
    }
  }
  std::stable_sort(uses.begin(), uses.end(), [](const ConstraintUse& a, const ConstraintUse& b) {
    return a.residual < b.residual;
  });
  p.maps.assign(factors.size(), FactorMap{});
  // The parameters a factor's blocks depend on: the union of theirs (one block's are sorted and
  // distinct already).
  const auto union_of_blocks = [&](const Factor& f, std::vector<int>* parameters) {
    for (int b : f.blocks) {
      parameters->insert(parameters->end(), p.red.block_parameters[b].begin(),
                         p.red.block_parameters[b].end());
    }
    if (f.blocks.size() > 1) {
      std::sort(parameters->begin(), parameters->end());
      parameters->erase(std::unique(parameters->begin(), parameters->end()), parameters->end());
    }
  };
  for (size_t i = 0; i < factors.size(); ++i) {
    const Factor& f = factors[i];
    FactorMap& map = p.maps[i];
    int column = 0;
    map.first_column.reserve(f.blocks.size());
    for (size_t s = 0; s < f.blocks.size(); ++s) {
      const Block& b = graph.blocks[f.blocks[s]];
      map.first_column.push_back(column);
      column += TangentDim(b.kind);
      if (b.kind == BlockKind::kSlack) map.slack_slot = static_cast<int>(s);
    }
    if (!f.is_constraint()) {
      union_of_blocks(f, &map.parameters);
      map.whitened = Whitening(f.noise, &map.whiten);
      continue;
    }
    const auto [first, last] = std::equal_range(
        uses.begin(), uses.end(), ConstraintUse{f.residual.get()},
        [](const ConstraintUse& a, const ConstraintUse& b) { return a.residual < b.residual; });
    for (auto use = first; use != last; ++use) {
      map.held = map.held || use->held;
      if (use->limit_joint < 0) continue;
      const int j = use->limit_joint;
      map.limit = dynamic_cast<const JointLimitResidual*>(f.residual.get());
      if (map.limit) map.limit_joint = j;
    }
    // A limit moves with its joint's variable alone; a held constraint with nothing (no step
    // reads it).
    if (map.limit) {
      map.parameters = {forest.joint_parameter[forest.leader[map.limit_joint]]};
    } else if (!map.held || map.slack_slot >= 0) {
      union_of_blocks(f, &map.parameters);
    }
    if (map.slack_slot >= 0) {
      p.red.block_parameters[f.blocks[map.slack_slot]] = map.parameters;
      ++p.eliminated_slacks;
    } else if (!map.held) {
      p.constraint_rows += f.residual->dimension();
    }
  }
  return "";
}

// Buffers of the per-factor and per-pose work, reused across iterations. The products are
// small (a marker's rows, a pose's six coordinates), lazily evaluated: a general product's
// blocking costs more than the arithmetic at these sizes.
struct Scratch {
  Eigen::VectorXd r, Wr, Jtr;
  Eigen::MatrixXd J, Jw, Tf, Jz, JtJ;
  Eigen::Matrix<double, 6, Eigen::Dynamic> Tb, ITb;  // ProjectPoses's, as wide as the parameters
  std::vector<Matrix6> information;                  // per block, in its own tangent
  std::vector<Vector6> gradient;

  Scratch(const ConstraintGraph& graph, int parameters)
      : Tb(6, parameters),
        ITb(6, parameters),
        information(graph.blocks.size()),
        gradient(graph.blocks.size()) {}
};

// H(p, p) += Jᵀ J, g(p) += Jᵀ r for the parameters p.
void Accumulate(const std::vector<int>& p, const Eigen::MatrixXd& J, const Eigen::VectorXd& r,
                Eigen::MatrixXd* H, Eigen::VectorXd* g, Scratch* s) {
  s->JtJ.noalias() = J.transpose().lazyProduct(J);
  s->Jtr.noalias() = J.transpose().lazyProduct(r);
  for (size_t k = 0; k < p.size(); ++k) {
    (*g)[p[k]] += s->Jtr[static_cast<Eigen::Index>(k)];
    for (size_t l = 0; l < p.size(); ++l) {
      (*H)(p[k], p[l]) += s->JtJ(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(l));
    }
  }
}

// I += Jwᵀ Jw for a measurement's whitened rows on one pose (six columns): the lower triangle's
// 21 column products, then mirrored.
void AddInformation(const Eigen::MatrixXd& Jw, Matrix6* information) {
  for (int c = 0; c < 6; ++c) {
    for (int d = c; d < 6; ++d) (*information)(d, c) += Jw.col(d).dot(Jw.col(c));
  }
  information->triangularView<Eigen::StrictlyUpper>() = information->transpose();
}

// Each pose's information and gradient gathered in its tangent (`s`) moved onto the parameters
// that move it: H(p, p) += Tbᵀ I Tb, g(p) += Tbᵀ v, Tb its rows of G on its parameters p. H is
// symmetric: each pose's lower triangle is added (p ascends), and the upper mirrored once.
void ProjectPoses(const ConstraintGraph& graph, const Reduction& red, const Eigen::MatrixXd& G,
                  Scratch* s, Eigen::MatrixXd* H, Eigen::VectorXd* g) {
  for (size_t b = 0; b < graph.blocks.size(); ++b) {
    if (graph.blocks[b].kind != BlockKind::kPose) continue;
    const std::vector<int>& p = red.block_parameters[b];
    const int o = graph.blocks[b].tangent_offset;
    const auto np = static_cast<Eigen::Index>(p.size());
    auto Tb = s->Tb.leftCols(np);
    auto ITb = s->ITb.leftCols(np);
    for (Eigen::Index k = 0; k < np; ++k) Tb.col(k) = G.block<6, 1>(o, p[k]);
    ITb.noalias() = s->information[b].lazyProduct(Tb);
    for (Eigen::Index k = 0; k < np; ++k) {
      (*g)[p[k]] += Tb.col(k).dot(s->gradient[b]);
      for (Eigen::Index l = 0; l <= k; ++l) (*H)(p[k], p[l]) += Tb.col(k).dot(ITb.col(l));
    }
  }
  H->triangularView<Eigen::StrictlyUpper>() = H->transpose();
}

// A measurement's whitened rows at `values` (W r, W J in s->Wr, s->Jw), or false where they
// are not finite or W is not defined.
bool Whitened(const ConstraintGraph& graph, const Factor& f, const FactorMap& map,
              const Values& values, Scratch* s) {
  EvaluateResidual(*f.residual, graph.blocks, f.blocks, values, &s->r, &s->J);
  if (!map.whitened || !s->r.allFinite() || !s->J.allFinite()) return false;
  s->Jw.resize(s->J.rows(), s->J.cols());
  s->Wr.resize(s->r.size());
  const Eigen::Index columns = s->J.cols();
  for (const auto& [first, size, offset] : map.whiten.blocks) {  // a marker's few rows
    const double* W = map.whiten.values.data() + offset;         // lower, column-major
    if (size == 1) {
      s->Jw.row(first) = W[0] * s->J.row(first);
      s->Wr[first] = W[0] * s->r[first];
      continue;
    }
    if (size == 3) {  // a 3D marker's, at its fixed size
      const Eigen::Map<const Eigen::Matrix3d> W3(W);
      s->Jw.middleRows<3>(first).noalias() =
          W3.triangularView<Eigen::Lower>() * s->J.middleRows<3>(first);
      s->Wr.segment<3>(first).noalias() =
          W3.triangularView<Eigen::Lower>() * s->r.segment<3>(first);
      continue;
    }
    for (int i = 0; i < size; ++i) {
      s->Jw.row(first + i).setZero();
      s->Wr[first + i] = 0;
      for (int k = 0; k <= i; ++k) {
        const double w = W[k * size + i];
        for (Eigen::Index c = 0; c < columns; ++c) s->Jw(first + i, c) += w * s->J(first + k, c);
        s->Wr[first + i] += w * s->r[first + k];
      }
    }
  }
  return true;
}

// A multi-block factor's Jacobian s->J on its parameters, in s->Jz.
void OnParameters(const ConstraintGraph& graph, const Factor& f, const FactorMap& map,
                  const Eigen::MatrixXd& J, const Eigen::MatrixXd& G, Scratch* s) {
  FactorTangent(graph, f, map, G, &s->Tf);
  s->Jz.noalias() = J * s->Tf;
}

// A linearisation's measurement information, as the fit analysis reads it: each pose's in its
// own tangent, a multi-block measurement's on the parameters, and G there.
struct Measured {
  std::vector<Matrix6> poses;
  Eigen::MatrixXd multi;
  Eigen::MatrixXd G;
};

// The measurements' χ² at `values` over their rows (`residuals`), those not finite or without
// a whitening left out as AnalyseAt leaves them out.
void Chi2At(const ConstraintGraph& graph, const std::vector<Factor>& factors,
            const Problem& problem, const Values& values, Scratch* s, double* chi2,
            int* residuals) {
  *chi2 = 0;
  *residuals = 0;
  for (size_t i = 0; i < factors.size(); ++i) {
    const Factor& f = factors[i];
    const FactorMap& map = problem.maps[i];
    if (f.is_constraint()) continue;
    EvaluateResidual(*f.residual, graph.blocks, f.blocks, values, &s->r, nullptr);
    if (!map.whitened || !s->r.allFinite()) continue;
    for (const auto& [first, size, offset] : map.whiten.blocks) {
      const double* W = map.whiten.values.data() + offset;  // lower, column-major
      for (int k = 0; k < size; ++k) {
        double w_r = 0;
        for (int l = 0; l <= k; ++l) w_r += W[l * size + k] * s->r[first + l];
        *chi2 += w_r * w_r;
      }
    }
    *residuals += static_cast<int>(s->r.size());
  }
}

// The fit analysis of AnalyseReducedFit at `values` with the measurements' information and
// the constraint rows C (on the parameters) of a linearisation there or a tenth of a sigma
// away; false when the measurements leave directions free.
bool AnalyseFrom(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                 const Problem& problem, const Values& values, const Measured& measured,
                 const Eigen::MatrixXd& C, Scratch* s, FitAnalysis* out) {
  const Forest& forest = problem.red.forest;
  const int nz = forest.size;
  FitAnalysis analysis;
  analysis.state_dim = graph.tangent_dim();
  Chi2At(graph, factors, problem, values, s, &analysis.fit.chi2, &analysis.fit.residuals);
  for (size_t b = 0; b < graph.blocks.size(); ++b) {
    s->information[b] = measured.poses[b];
    s->gradient[b].setZero();
  }
  Eigen::MatrixXd information = measured.multi;
  Eigen::VectorXd unused = Eigen::VectorXd::Zero(nz);
  ProjectPoses(graph, problem.red, measured.G, s, &information, &unused);
  // Columns scaled as AnalyseFit scales them: a length in units of the extent, an angle in rad.
  const Eigen::Map<const Eigen::VectorXd> scale(forest.prior_sigma.data(), nz);
  Eigen::MatrixXd constraints = C * scale.asDiagonal();
  int kept = 0;
  for (Eigen::Index k = 0; k < C.rows(); ++k) {
    const double norm = constraints.row(k).norm();
    if (norm > 0) constraints.row(kept++) = constraints.row(k) / norm;
  }
  constraints.conservativeResize(kept, nz);
  const Eigen::MatrixXd scaled = scale.asDiagonal() * information * scale.asDiagonal();
  if (FreeDirections(constraints, scaled, &analysis.model_dof, &analysis.determined).cols() > 0) {
    return false;
  }
  analysis.fit.dof = std::max(0, analysis.fit.residuals - analysis.determined);
  analysis.fit.p_value =
      analysis.fit.dof > 0 ? 1 - ChiSquareCdf(analysis.fit.chi2, analysis.fit.dof) : 1.0;
  *out = std::move(analysis);
  return true;
}

// AnalyseFrom with a linearisation at `values` itself, G the poses' derivative there.
bool AnalyseAt(const ConstraintGraph& graph, const std::vector<Factor>& factors,
               const Problem& problem, const Values& values, const Eigen::MatrixXd& G, Scratch* s,
               FitAnalysis* out) {
  const int nz = problem.red.forest.size;
  Measured measured;
  measured.poses.assign(graph.blocks.size(), Matrix6::Zero());
  measured.multi.setZero(nz, nz);
  measured.G = G;
  Eigen::MatrixXd C(problem.constraint_rows, nz);
  Eigen::VectorXd unused = Eigen::VectorXd::Zero(nz);
  int rows = 0;
  for (size_t i = 0; i < factors.size(); ++i) {
    const Factor& f = factors[i];
    const FactorMap& map = problem.maps[i];
    if (map.held || map.slack_slot >= 0) continue;  // held by the parameters, or by their slack
    if (f.is_constraint()) {
      EvaluateResidual(*f.residual, graph.blocks, f.blocks, values, &s->r, &s->J);
      if (!s->r.allFinite() || !s->J.allFinite()) continue;
      OnParameters(graph, f, map, s->J, G, s);
      for (int k = 0; k < s->Jz.rows(); ++k) {
        C.row(rows).setZero();
        for (size_t l = 0; l < map.parameters.size(); ++l) {
          C(rows, map.parameters[l]) = s->Jz(k, static_cast<Eigen::Index>(l));
        }
        ++rows;
      }
      continue;
    }
    if (!Whitened(graph, f, map, values, s)) continue;
    if (f.blocks.size() == 1) {
      AddInformation(s->Jw, &measured.poses[f.blocks[0]]);
    } else {
      OnParameters(graph, f, map, s->Jw, G, s);
      Accumulate(map.parameters, s->Jz, s->Wr, &measured.multi, &unused, s);
    }
  }
  return AnalyseFrom(graph, factors, problem, values, measured, C.topRows(rows), s, out);
}

}  // namespace

std::string ReducedUnsupported(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                               int* parameters) {
  Forest forest;
  if (std::string why = Structure(graph, &forest); !why.empty()) return why;
  if (std::string why = SlackUse(graph, factors); !why.empty()) return why;
  if (parameters) *parameters = ParameterCount(graph, forest);
  return "";
}

int ReducedParameters(const ConstraintGraph& graph) {
  Forest forest;
  return Structure(graph, &forest).empty() ? ParameterCount(graph, forest) : 0;
}

ReducedSummary SolveReduced(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                            const Values& prior_mean, const Eigen::VectorXd& prior_variance,
                            ReducedEstimate* estimate, const ReducedOptions& options,
                            const Values* initial, const std::vector<std::pair<int, int>>* pairs) {
  ReducedSummary summary;
  Problem problem;
  summary.unsupported =
      Prepare(graph, factors, options.fit_extent > 0 ? options.fit_extent : 1.0, &problem);
  if (!summary.unsupported.empty()) return summary;
  const Reduction& red = problem.red;
  std::vector<FactorMap>& maps = problem.maps;
  const Forest& forest = red.forest;
  const int nz = forest.size;
  summary.parameters = nz;
  if (nz > options.max_parameters) {
    summary.unsupported = fmt::format("{} parameters, more than {}", nz, options.max_parameters);
    return summary;
  }
  const int n = graph.tangent_dim();
  const int m = problem.constraint_rows;
  CFUSE_CHECK_EQ(prior_variance.size(), n);
  summary.eliminated_slacks = problem.eliminated_slacks;
  summary.constraint_rows = m;

  const Values& start = initial ? *initial : prior_mean;
  Configuration x = FromPoses(graph, forest, start);
  Values values = prior_mean;
  values.slacks = start.slacks;
  Eigen::MatrixXd G;
  ComponentPoses(graph, forest, red.influence, x, &values, &G);
  const auto constraints_hold = [&] {
    Eigen::VectorXd r;
    for (size_t i = 0; i < factors.size(); ++i) {
      if (!factors[i].is_constraint() || maps[i].held) continue;
      EvaluateResidual(*factors[i].residual, graph.blocks, factors[i].blocks, values, &r, nullptr);
      if (!(r.lpNorm<Eigen::Infinity>() <= options.constraint_tolerance)) return false;
    }
    return true;
  };

  // An eliminated slack moved back onto its row at the new parameters, by Newton's method on
  // λ alone: the step's linearisation leaves the row off by about the square of λ's step, and
  // closing it here spares an iteration that would only close it. A row that λ cannot close
  // (at or past its boundary) keeps the linearised λ.
  const auto CloseSlack = [&](const Factor& f, const FactorMap& map, Eigen::VectorXd* r) {
    double& lambda = values.slacks[graph.blocks[f.blocks[map.slack_slot]].index];
    double last = INFINITY, before = lambda;
    for (int round = 0; round < 4; ++round) {
      double c = 0, a_lambda = map.a_lambda;
      if (map.limit_joint >= 0) {
        const int j = map.limit_joint;
        const double q = forest.multiplier[j] * x.q[forest.leader[j]] + forest.offset[j];
        using Dual = Eigen::AutoDiffScalar<Eigen::Matrix<double, 1, 1>>;  // d/dλ alone
        const Dual v = map.limit->AtValue(Dual(q, Eigen::Matrix<double, 1, 1>::Zero()),
                                          Dual(lambda, Eigen::Matrix<double, 1, 1>::Ones()));
        c = v.value();
        a_lambda = v.derivatives()[0];
      } else {  // the chord: the step's own a_λ
        EvaluateResidual(*f.residual, graph.blocks, f.blocks, values, r, nullptr);
        c = (*r)[0];
      }
      if (!(std::abs(c) > 1e-3 * options.constraint_tolerance)) return;  // closed, or NaN
      if (!(std::abs(c) < 0.5 * last)) {  // not converging: the last good λ
        lambda = before;
        return;
      }
      if (!(std::abs(a_lambda) > 1e-12)) return;
      last = std::abs(c);
      before = lambda;
      lambda -= c / a_lambda;
    }
  };

  Scratch s(graph, nz);
  Eigen::MatrixXd H(nz, nz), C(m, nz), Linv, LinvYt;
  Eigen::VectorXd g(nz), c(m);
  // The last linearisation's measurement information, which a converged answer's fit analysis
  // reads: a step of a tenth of a sigma changes no rank, and the Jacobians are most of a
  // linearisation's cost.
  const bool analyse = options.fit_extent > 0;
  Measured measured;
  if (analyse) {
    measured.poses.resize(graph.blocks.size());
    measured.multi.resize(nz, nz);
  }
  bool factored = false;  // Linv and LinvYt hold the last iteration's
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    H.setZero();
    g.setZero();
    if (analyse) measured.multi.setZero();
    for (size_t b = 0; b < graph.blocks.size(); ++b) {
      s.information[b].setZero();
      s.gradient[b].setZero();
    }
    int row = 0;
    bool finite = true;
    for (size_t i = 0; i < factors.size() && finite; ++i) {
      const Factor& f = factors[i];
      FactorMap& map = maps[i];
      if (map.held) continue;
      if (!f.is_constraint()) {
        finite = Whitened(graph, f, map, values, &s);
        if (!finite) break;
        if (f.blocks.size() == 1) {
          AddInformation(s.Jw, &s.information[f.blocks[0]]);
          s.gradient[f.blocks[0]].noalias() += s.Jw.transpose().lazyProduct(s.Wr);
        } else {
          OnParameters(graph, f, map, s.Jw, G, &s);
          // Kept apart for the fit analysis, and added to H whole below.
          Accumulate(map.parameters, s.Jz, s.Wr, analyse ? &measured.multi : &H, &g, &s);
        }
        continue;
      }
      if (map.limit_joint >= 0) {
        const int j = map.limit_joint;
        const double q = forest.multiplier[j] * x.q[forest.leader[j]] + forest.offset[j];
        const double slack = values.slacks[graph.blocks[f.blocks[map.slack_slot]].index];
        using Dual = Eigen::AutoDiffScalar<Eigen::Vector2d>;  // d/dq and d/dλ
        const Dual v = map.limit->AtValue(Dual(q, Eigen::Vector2d::UnitX()),
                                          Dual(slack, Eigen::Vector2d::UnitY()));
        map.c = v.value();
        map.a.resize(1);
        map.a[0] = v.derivatives()[0] * forest.multiplier[j];
        map.a_lambda = v.derivatives()[1];
      } else {
        EvaluateResidual(*f.residual, graph.blocks, f.blocks, values, &s.r, &s.J);
        finite = s.r.allFinite() && s.J.allFinite();
        if (!finite) break;
        OnParameters(graph, f, map, s.J, G, &s);
        if (map.slack_slot < 0) {
          C.middleRows(row, s.r.size()).setZero();
          for (size_t k = 0; k < map.parameters.size(); ++k) {
            C.block(row, map.parameters[k], s.r.size(), 1) = s.Jz.col(static_cast<Eigen::Index>(k));
          }
          c.segment(row, s.r.size()) = s.r;
          row += static_cast<int>(s.r.size());
          continue;
        }
        map.c = s.r[0];
        map.a = s.Jz.row(0);
        map.a_lambda = s.J(0, map.first_column[map.slack_slot]);
      }
      // The slack eliminated with its row: λ's prior, w (λ + Δλ - λ0)², is a measurement of z.
      // A vanishing a_λ is λ on the boundary, which the filter decides.
      const Block& slack_block = graph.blocks[f.blocks[map.slack_slot]];
      finite = std::isfinite(map.c) && map.a.allFinite() && std::abs(map.a_lambda) > 1e-12;
      if (!finite) break;
      const double w = 1 / std::sqrt(prior_variance[slack_block.tangent_offset]);
      const double lambda = values.slacks[slack_block.index];
      const double lambda0 = prior_mean.slacks[slack_block.index];
      const double gain = -w / map.a_lambda;
      const double residual = w * (lambda - lambda0 - map.c / map.a_lambda);
      for (size_t k = 0; k < map.parameters.size(); ++k) {
        const double ak = gain * map.a[static_cast<Eigen::Index>(k)];
        g[map.parameters[k]] += ak * residual;
        for (size_t l = 0; l < map.parameters.size(); ++l) {
          H(map.parameters[k], map.parameters[l]) +=
              ak * gain * map.a[static_cast<Eigen::Index>(l)];
        }
      }
    }
    if (finite) {
      if (analyse) {  // the measurements' part, kept for the fit analysis
        for (size_t b = 0; b < graph.blocks.size(); ++b) measured.poses[b] = s.information[b];
        H += measured.multi;
      }
      // Each pose's information and gradient gathered in its own tangent (6 x 6, whatever the
      // parameters) are moved onto the parameters that move it once. The prior is in the chart
      // at the prior mean: δ = (Log(R0ᵀ R), t - t0), whose derivative in the chart at R is
      // Jr(δθ)⁻¹ on the rotation.
      for (size_t b = 0; b < graph.blocks.size(); ++b) {
        const Block& block = graph.blocks[b];
        if (block.kind != BlockKind::kPose) continue;
        const Rigid3d& pose = values.poses[block.index];
        const Rigid3d& pose0 = prior_mean.poses[block.index];
        Vector6 delta;
        delta.head<3>() = LogSO3(pose0.rotation.conjugate() * pose.rotation);
        delta.tail<3>() = pose.translation - pose0.translation;
        const Eigen::Matrix3d D = InverseRightJacobianSO3(delta.head<3>());  // and I on t
        const Vector6 w = prior_variance.segment<6>(block.tangent_offset).cwiseInverse();
        Matrix6& information = s.information[b];
        information.topLeftCorner<3, 3>().noalias() += D.transpose() * w.head<3>().asDiagonal() * D;
        information.bottomRightCorner<3, 3>().diagonal() += w.tail<3>();
        s.gradient[b].head<3>().noalias() +=
            D.transpose() * w.head<3>().cwiseProduct(delta.head<3>());
        s.gradient[b].tail<3>() += w.tail<3>().cwiseProduct(delta.tail<3>());
      }
      ProjectPoses(graph, red, G, &s, &H, &g);
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(H);
    if (!finite || llt.info() != Eigen::Success) {
      summary.factorized = false;
      break;
    }
    // H⁻¹ = Linvᵀ Linv, for the parameters' variances (the step test) and the covariance.
    Linv = LowerTriangularInverse(llt.matrixLLT());
    const Eigen::VectorXd free_step = -llt.solve(g);
    Eigen::VectorXd step = free_step;
    Eigen::VectorXd variance_z = Linv.colwise().squaredNorm().transpose();
    LinvYt.resize(0, nz);
    summary.dependent_rows = 0;
    if (m > 0) {
      // The constraint rows by their Schur complement S = C H⁻¹ Cᵀ, each kept when its pivot
      // is above the dependence tolerance of its own variance.
      const Eigen::MatrixXd Y = llt.solve(C.transpose());
      const Eigen::MatrixXd S = C * Y;
      std::vector<int> kept;
      Eigen::MatrixXd L(m, m);
      for (int i = 0; i < m; ++i) {
        const int k = static_cast<int>(kept.size());
        Eigen::VectorXd l(k);
        for (int a = 0; a < k; ++a) l[a] = S(kept[a], i);
        if (k > 0) L.topLeftCorner(k, k).triangularView<Eigen::Lower>().solveInPlace(l);
        const double pivot = S(i, i) - l.squaredNorm();
        if (!(pivot > options.dependence_tolerance * S(i, i))) continue;
        L.block(k, 0, 1, k) = l.transpose();
        L(k, k) = std::sqrt(pivot);
        kept.push_back(i);
      }
      const int nk = static_cast<int>(kept.size());
      summary.dependent_rows = m - nk;
      Eigen::MatrixXd Yk(nz, nk);
      Eigen::VectorXd ck(nk);
      for (int a = 0; a < nk; ++a) {
        Yk.col(a) = Y.col(kept[a]);
        ck[a] = c[kept[a]] + C.row(kept[a]).dot(free_step);
      }
      const auto Lk = L.topLeftCorner(nk, nk).triangularView<Eigen::Lower>();
      const Eigen::VectorXd mu = Lk.transpose().solve(Lk.solve(ck));
      step -= Yk * mu;
      // Cov(z) on the constraint surface: H⁻¹ - Y S⁻¹ Yᵀ over the rows kept, = Linvᵀ Linv -
      // LinvYtᵀ LinvYt.
      LinvYt = Lk.solve(Yk.transpose());
      variance_z -= LinvYt.colwise().squaredNorm().transpose();
    }
    factored = true;

    std::swap(G, measured.G);  // the linearisation's, for the fit analysis
    Retract(graph, forest, step, &x);
    for (size_t i = 0; i < factors.size(); ++i) {
      const FactorMap& map = maps[i];
      if (map.held || map.slack_slot < 0) continue;
      double moved = map.c;
      for (size_t k = 0; k < map.parameters.size(); ++k) {
        moved += map.a[static_cast<Eigen::Index>(k)] * step[map.parameters[k]];
      }
      values.slacks[graph.blocks[factors[i].blocks[map.slack_slot]].index] -= moved / map.a_lambda;
    }
    ComponentPoses(graph, forest, red.influence, x, &values, &G);
    for (size_t i = 0; i < factors.size(); ++i) {
      if (!maps[i].held && maps[i].slack_slot >= 0) CloseSlack(factors[i], maps[i], &s.r);
    }
    summary.iterations = iteration + 1;
    bool settled = options.settled_fraction > 0;
    for (int k = 0; k < nz && settled; ++k) {
      const double sigma = std::sqrt(std::max(variance_z[k], 0.0));
      settled = std::abs(step[k]) <= options.settled_fraction * sigma + 1e-10;
    }
    if (step.lpNorm<Eigen::Infinity>() <= options.step_tolerance ||
        (settled && constraints_hold())) {
      summary.converged = true;
      break;
    }
  }
  estimate->mean = values;
  estimate->covariance.resize(0, 0);
  if (summary.factorized && factored) {
    // T = dx/dz at the solution: the poses' rows G, each eliminated slack's -a / a_λ.
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n, nz);
    T.leftCols(nz) = G;
    for (size_t i = 0; i < factors.size(); ++i) {
      const FactorMap& map = maps[i];
      if (map.held || map.slack_slot < 0) continue;
      const int o = graph.blocks[factors[i].blocks[map.slack_slot]].tangent_offset;
      for (size_t k = 0; k < map.parameters.size(); ++k) {
        T(o, map.parameters[k]) = -map.a[static_cast<Eigen::Index>(k)] / map.a_lambda;
      }
    }
    Eigen::MatrixXd& P = estimate->covariance;
    if (!pairs) {
      // T Cov(z) Tᵀ = B Bᵀ - E Eᵀ, B = T Linvᵀ, E = T LinvYtᵀ: half the work of Cov(z) and the
      // product with T's transpose (B's by Linv's triangle).
      const Eigen::MatrixXd B = T * Linv.transpose().triangularView<Eigen::Upper>();
      P.resize(n, n);
      P.triangularView<Eigen::Lower>() = B * B.transpose();
      if (LinvYt.rows() > 0) {
        const Eigen::MatrixXd E = T * LinvYt.transpose();
        P.triangularView<Eigen::Lower>() -= E * E.transpose();
      }
      P.triangularView<Eigen::StrictlyUpper>() = P.transpose();
    } else {
      Eigen::MatrixXd covariance_z = Linv.transpose() * Linv;
      if (LinvYt.rows() > 0) covariance_z.noalias() -= LinvYt.transpose() * LinvYt;
      // A block's rows of T are zero outside the parameters that move it.
      P.setConstant(n, n, NAN);
      const auto rows_of = [&](int block) {
        const Block& b = graph.blocks[block];
        const std::vector<int>& p = red.block_parameters[block];
        Eigen::MatrixXd Tp(TangentDim(b.kind), p.size());
        for (size_t k = 0; k < p.size(); ++k) {
          Tp.col(static_cast<Eigen::Index>(k)) = T.block(b.tangent_offset, p[k], Tp.rows(), 1);
        }
        return Tp;
      };
      const auto put = [&](int a, int b) {
        const std::vector<int>&pa = red.block_parameters[a], &pb = red.block_parameters[b];
        Eigen::MatrixXd S(pa.size(), pb.size());
        for (size_t k = 0; k < pa.size(); ++k) {
          for (size_t l = 0; l < pb.size(); ++l) {
            S(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(l)) =
                covariance_z(pa[k], pb[l]);
          }
        }
        const Eigen::MatrixXd cov = rows_of(a) * S * rows_of(b).transpose();
        const Block &ba = graph.blocks[a], &bb = graph.blocks[b];
        P.block(ba.tangent_offset, bb.tangent_offset, cov.rows(), cov.cols()) = cov;
        P.block(bb.tangent_offset, ba.tangent_offset, cov.cols(), cov.rows()) = cov.transpose();
      };
      for (size_t b = 0; b < graph.blocks.size(); ++b)
        put(static_cast<int>(b), static_cast<int>(b));
      for (const auto& [a, b] : *pairs) put(a, b);
    }
  }
  Eigen::VectorXd r;
  for (const Factor& f : factors) {
    if (!f.is_constraint()) continue;
    EvaluateResidual(*f.residual, graph.blocks, f.blocks, values, &r, nullptr);
    summary.max_constraint_residual =
        std::max(summary.max_constraint_residual, r.lpNorm<Eigen::Infinity>());
  }
  estimate->analysed =
      summary.converged && analyse && factored &&
      AnalyseFrom(graph, factors, problem, values, measured, C, &s, &estimate->analysis);
  return summary;
}

bool AnalyseReducedFit(const ConstraintGraph& graph, const std::vector<Factor>& factors,
                       const Values& values, double extent, FitAnalysis* out) {
  Problem problem;
  if (!Prepare(graph, factors, extent, &problem).empty()) return false;
  const Forest& forest = problem.red.forest;
  Values at = values;
  Eigen::MatrixXd G;
  ComponentPoses(graph, forest, problem.red.influence, FromPoses(graph, forest, values), &at, &G);
  Scratch s(graph, forest.size);
  return AnalyseAt(graph, factors, problem, values, G, &s, out);
}

}  // namespace cfuse::internal
