// Gating and scoring: the Mahalanobis gate of a prediction, Lowe's match probability p/(p+q)
// against the clutter density, joint compatibility along a branch, and a labelling's score.
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>
#include <unordered_map>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/interp/closed_form_pose.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/combined_constraint.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/image_point.h"
#include "cfuse/kernel/measurements/point3.h"
#include "interpreter.h"

namespace cfuse::internal {

double Interpreter::Gate(int dof) const {
  if (static_cast<int>(gates_.size()) <= dof) gates_.resize(dof + 1, -1);
  if (gates_[dof] < 0) {
    thread_local std::map<std::pair<double, int>, double> known;
    const auto key = std::make_pair(options_.gate_confidence, dof);
    auto it = known.find(key);
    if (it == known.end()) {
      it = known.emplace(key, ChiSquareQuantile(options_.gate_confidence, dof)).first;
    }
    gates_[dof] = it->second;
  }
  return gates_[dof];
}

bool Interpreter::JointlyCompatible(const Frame& f) const {
  if (!options_.joint_compatibility || f.nis_dof == 0) return true;
  return f.nis_sum <= Gate(f.nis_dof);
}

template <int N>
bool Interpreter::Mahalanobis(const Prediction& p, const Eigen::Matrix<double, N, 1>& z,
                              const Eigen::Matrix<double, N, N>& noise, double* delta,
                              double* log_det) {
  if (p.mean.size() != N) return false;
  const Eigen::Matrix<double, N, 1> d = Eigen::Matrix<double, N, 1>(p.mean) - z;
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(Eigen::Matrix<double, N, N>(p.covariance) +
                                                    noise);
  if (llt.info() != Eigen::Success) return false;
  *delta = d.dot(llt.solve(d));
  *log_det = 2 * llt.matrixLLT().diagonal().array().log().sum();
  return true;
}

std::optional<Candidate> Interpreter::Score(const Prediction& p, int m, bool gated) const {
  const MeasuredPoint& z = set_.points[m];
  if (!p.valid) return std::nullopt;
  double delta = 0, log_det = 0;
  if (!(z.is_3d ? Mahalanobis<3>(p, z.xyz, z.cov3, &delta, &log_det)
                : Mahalanobis<2>(p, z.uv, z.cov2, &delta, &log_det))) {
    return std::nullopt;
  }
  if (gated && !(delta <= (z.is_3d ? gate3_ : gate2_))) return std::nullopt;
  if (!std::isfinite(delta)) return std::nullopt;
  const int dims = z.is_3d ? 3 : 2;
  const double log_p = -0.5 * delta - 0.5 * (dims * std::log(kTwoPi) + log_det);
  const double q = z.is_3d ? clutter3_ : clutter2_;
  // p / (p + q), from log p without overflow.
  const double probability = 1 / (1 + q * std::exp(-log_p));
  // Clutter points expected inside the gate: q times the gate ellipsoid's volume. Where it
  // is 1 or more the prediction says little, and p/(p+q) cannot tell a match from clutter.
  const double dim = static_cast<double>(dims);
  const double gate = z.is_3d ? gate3_ : gate2_;
  const double unit_ball = dim == 3 ? 4.18879020478639 : 3.14159265358979;
  const double in_gate = q * unit_ball * std::pow(gate, dim / 2) * std::exp(0.5 * log_det);
  return Candidate{m, delta, probability, in_gate < 1, log_p - std::log(q)};
}

double Interpreter::LabellingScore(int context, const std::vector<int>& assignment,
                                   const GaussianState& state) const {
  double total = 0;
  for (int l = 0; l < levels_; ++l) {
    if (assignment[l] < 0) continue;
    const auto [p3, p2] = PredictPoint(contexts_[context].points[l], state);
    const std::optional<Candidate> c =
        Score(set_.points[assignment[l]].is_3d ? p3 : p2, assignment[l], false);
    total += c ? c->log_ratio : -1e300;
  }
  return total;
}

std::pair<Prediction, Prediction> Interpreter::PredictWithOwn(const Frame& f,
                                                              ModelPointRef point) const {
  if (f.own.empty()) return PredictPoint(point, f.state);
  std::vector<int> involved = {g_.components[point.component].block};
  for (int k : f.own) {
    for (int b : g_.constraints[k].blocks) {
      if (std::find(involved.begin(), involved.end(), b) == involved.end()) involved.push_back(b);
    }
  }
  GaussianState m;
  std::vector<int> remap(g_.blocks.size(), -1), coordinates;
  int counts[3] = {0, 0, 0}, offset = 0;
  for (int b : involved) {
    Block block = g_.blocks[b];
    const int dim = TangentDim(block.kind);
    for (int i = 0; i < dim; ++i) coordinates.push_back(block.tangent_offset + i);
    switch (block.kind) {
      case BlockKind::kPose:
        m.mean.poses.push_back(f.state.mean.poses[block.index]);
        break;
      case BlockKind::kPoint:
        m.mean.points.push_back(f.state.mean.points[block.index]);
        break;
      case BlockKind::kSlack:
        m.mean.slacks.push_back(f.state.mean.slacks[block.index]);
        break;
    }
    block.index = counts[static_cast<int>(block.kind)]++;
    block.tangent_offset = offset;
    offset += dim;
    remap[b] = static_cast<int>(m.blocks.size());
    m.blocks.push_back(block);
  }
  m.covariance = f.state.covariance(coordinates, coordinates);
  m.prior_variance = f.state.prior_variance(coordinates);
  auto local = [&](std::vector<int> blocks) {
    for (int& b : blocks) b = remap[b];
    return blocks;
  };
  for (int k : f.own) {
    const Constraint& c = g_.constraints[k];
    Fuse({c.residual, local(c.blocks), {}, c.name}, &m);
  }
  Prediction p3, p2;
  if (!index3_.empty()) {
    Factor factor = MeasurementFactor(g_, set_, point, -1, false);
    factor.blocks = local(factor.blocks);
    p3 = Predict(factor, m);
  }
  if (!index2_.empty()) {
    Factor factor = MeasurementFactor(g_, set_, point, -1, true);
    factor.blocks = local(factor.blocks);
    p2 = Predict(factor, m);
  }
  return {p3, p2};
}

std::pair<Prediction, Prediction> Interpreter::PredictPoint(ModelPointRef point,
                                                            const GaussianState& state) const {
  Prediction p3, p2;
  if (!index3_.empty()) p3 = Predict(MeasurementFactor(g_, set_, point, -1, false), state);
  if (!index2_.empty()) p2 = Predict(MeasurementFactor(g_, set_, point, -1, true), state);
  return {p3, p2};
}

std::vector<Candidate> Interpreter::LocusCandidates(const Frame& f, const std::vector<bool>& used,
                                                    const std::vector<bool>& listed) const {
  std::vector<Candidate> out;
  const ModelPointRef point = ctx_->points[f.level];
  if (g_.components[point.component].rigid || f.own.empty()) return out;
  const int point_block = g_.components[point.component].block;
  // Per own constraint, what does not depend on the candidate: the Jacobian columns of the
  // point and of the other blocks, and the other blocks' covariance.
  struct Own {
    const Constraint* constraint;
    std::vector<int> point_columns, other_columns;
    Eigen::MatrixXd others;  // covariance of the other blocks' tangent coordinates
    double loose = 0;        // a bound on |r|² no measurement inside the gate exceeds
  };
  std::vector<Own> own;
  if (max_trace3_ < 0) {
    max_trace3_ = 0;
    for (const MeasuredPoint& m : set_.points) {
      if (m.is_3d) max_trace3_ = std::max(max_trace3_, m.cov3.trace());
    }
  }
  Values moved = f.state.mean;
  Eigen::Vector3d& x = moved.points[g_.blocks[point_block].index];
  Eigen::VectorXd r;
  Eigen::MatrixXd H;
  for (int k : f.own) {
    Own o{&g_.constraints[k], {}, {}, {}, 0};
    std::vector<int> index;
    int column = 0;
    for (int b : o.constraint->blocks) {
      const Block& block = g_.blocks[b];
      for (int i = 0; i < TangentDim(block.kind); ++i, ++column) {
        if (b == point_block) {
          o.point_columns.push_back(column);
        } else {
          o.other_columns.push_back(column);
          index.push_back(block.tangent_offset + i);
        }
      }
    }
    o.others = f.state.covariance(index, index);
    // Most measurements lie far off the locus: a test on the residual alone rejects them
    // before its Jacobian is computed. Its variance is bounded by the one at the point's
    // current guess, with the largest measurement noise, times 100 (10 sigma of slack for
    // how the Jacobian turns between there and a candidate).
    EvaluateResidual(*o.constraint->residual, g_.blocks, o.constraint->blocks, moved, &r, &H);
    const Eigen::MatrixXd Hp = H(Eigen::all, o.point_columns);
    const Eigen::MatrixXd Ho = H(Eigen::all, o.other_columns);
    const Eigen::MatrixXd S0 = max_trace3_ * Hp * Hp.transpose() + Ho * o.others * Ho.transpose();
    const double largest = S0.rows() == 1 ? S0(0, 0) : S0.trace();
    o.loose = 100 * Gate(static_cast<int>(r.size())) * largest;
    if (!std::isfinite(o.loose)) o.loose = std::numeric_limits<double>::infinity();
    own.push_back(std::move(o));
  }
  std::vector<double> value;
  for (size_t m = 0; m < set_.points.size(); ++m) {
    if (used[m] || listed[m] || !set_.points[m].is_3d) continue;
    x = set_.points[m].xyz;
    bool near = true;
    for (const Own& o : own) {
      // The residual alone, into a reused buffer: this runs for most measurements.
      value.resize(static_cast<size_t>(o.constraint->residual->dimension()));
      EvaluateResidualAt(*o.constraint->residual, g_.blocks, o.constraint->blocks, moved, nullptr,
                         value.data(), nullptr);
      double squared = 0;
      for (double v : value) squared += v * v;
      if (!(squared <= o.loose)) {
        near = false;
        break;
      }
    }
    if (!near) continue;
    // Each own constraint evaluated with the point moved to the measurement; its variance
    // from the other blocks' covariance and the measurement's, through the Jacobian there.
    double nis = 0;
    bool inside = true;
    for (const Own& o : own) {
      EvaluateResidual(*o.constraint->residual, g_.blocks, o.constraint->blocks, moved, &r, &H);
      const Eigen::MatrixXd Hp = H(Eigen::all, o.point_columns);
      const Eigen::MatrixXd Ho = H(Eigen::all, o.other_columns);
      const Eigen::MatrixXd S =
          Hp * set_.points[m].cov3 * Hp.transpose() + Ho * o.others * Ho.transpose();
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
      const double e = r.dot(ldlt.solve(r));
      if (!std::isfinite(e) || e > Gate(static_cast<int>(r.size()))) {
        inside = false;
        break;
      }
      nis += e;
    }
    if (inside) out.push_back({static_cast<int>(m), nis, 0, false});
  }
  std::sort(out.begin(), out.end(),
            [](const Candidate& a, const Candidate& b) { return a.delta < b.delta; });
  return out;
}

}  // namespace cfuse::internal
