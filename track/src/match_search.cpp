#include "cfuse/track/match_search.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

class Search {
 public:
  Search(const ConstraintGraph& graph, const Camera& camera, const std::vector<Factor>& constraints,
         const FramePrior& prior, const std::vector<EdgeModel>& edges,
         const std::vector<EdgeCandidate>& candidates, int dof, const MatchSearchOptions& options)
      : graph_(graph),
        camera_(camera),
        constraints_(constraints),
        prior_(prior),
        edges_(edges),
        candidates_(candidates),
        dof_(dof),
        options_(options),
        probability_(candidates.size()) {
    for (size_t c = 0; c < candidates.size(); ++c) probability_[c] = candidates[c].probability;
  }

  MatchSearchResult Run(const std::function<Judgement(MatchedSet*)>& judge) {
    MatchSearchResult result;
    const int needed = (dof_ + 1) / 2;
    double best_score = -1;
    for (int branch = 0; branch < options_.max_branches; ++branch) {
      std::vector<int> set = NextSet(needed);
      if (static_cast<int>(set.size()) < needed) break;
      ++result.branches;
      MatchedSet trial;
      if (Solve(set, &trial)) {
        Extend(&trial);
        const Judgement j = judge(&trial);
        if (j.verified && j.score > best_score) {
          best_score = j.score;
          result.best = std::move(trial);
        }
        if (j.verified && j.confident) break;
      }
      for (int c : set) probability_[c] *= 1 - 1.0 / static_cast<double>(set.size());
      std::sort(set.begin(), set.end());
      rejected_.push_back(std::move(set));
    }
    result.estimation_ms = estimation_ms_;
    return result;
  }

 private:
  // The set, best first: each match taken tightens the prediction for the next.
  std::vector<int> NextSet(int needed) {
    std::vector<int> set;
    std::vector<bool> edge_used(edges_.size(), false);
    GaussianState given = prior_.constrained;
    std::vector<double> conditional = probability_;
    double product = 1;
    for (;;) {
      int best = -1;
      for (size_t c = 0; c < candidates_.size(); ++c) {
        if (edge_used[candidates_[c].edge]) continue;
        if (best >= 0 && conditional[c] <= conditional[best]) continue;
        if (CompletesRejected(set, static_cast<int>(c))) continue;
        best = static_cast<int>(c);
      }
      if (best < 0 || conditional[best] < options_.min_probability) break;
      if (static_cast<int>(set.size()) >= needed && product * conditional[best] < 0.9) break;
      set.push_back(best);
      edge_used[candidates_[best].edge] = true;
      product *= conditional[best];
      if (!options_.conditional_sets) continue;
      Fuse(Factor(best), &given);
      std::vector<EdgeModel> now = edges_;
      Reproject(graph_, camera_, given, &now);
      for (size_t c = 0; c < candidates_.size(); ++c) {
        if (edge_used[candidates_[c].edge]) continue;
        // (times what rejected sets took off it)
        conditional[c] =
            CandidateProbability(now[candidates_[c].edge], candidates_[c], options_.gate) *
            probability_[c] / candidates_[c].probability;
      }
    }
    return set;
  }

  bool CompletesRejected(const std::vector<int>& set, int c) const {
    if (rejected_.empty()) return false;
    std::vector<int> with = set;
    with.push_back(c);
    std::sort(with.begin(), with.end());
    return std::any_of(rejected_.begin(), rejected_.end(), [&](const std::vector<int>& r) {
      return std::includes(with.begin(), with.end(), r.begin(), r.end());
    });
  }

  cfuse::Factor Factor(int c) const {
    const EdgeCandidate& k = candidates_[c];
    return EdgeFactor(camera_, edges_[k.edge], k.a, k.b, k.noise);
  }

  bool Solve(const std::vector<int>& set, MatchedSet* out) {
    const auto t = Clock::now();
    std::vector<cfuse::Factor> factors;
    for (int c : set) factors.push_back(Factor(c));
    out->set = set;
    out->lines.clear();
    for (int c : set) {
      out->lines.push_back({edges_[candidates_[c].edge].edge, candidates_[c].a, candidates_[c].b});
    }
    const bool ok = SolveMatches(constraints_, prior_.free, factors, graph_.blocks, dof_,
                                 options_.accept_confidence, out);
    estimation_ms_ += Ms(t, Clock::now());
    return ok;
  }

  // Extended, round by round, with every candidate the tightened prediction supports, each
  // round solved again while it passes.
  void Extend(MatchedSet* matched) {
    for (int round = 0; round < 3; ++round) {
      std::vector<EdgeModel> tight = edges_;
      Reproject(graph_, camera_, matched->state, &tight);
      std::vector<bool> edge_used(edges_.size(), false);
      for (int c : matched->set) edge_used[candidates_[c].edge] = true;
      std::vector<std::pair<double, int>> supported;
      for (size_t c = 0; c < candidates_.size(); ++c) {
        if (edge_used[candidates_[c].edge]) continue;
        const double p =
            CandidateProbability(tight[candidates_[c].edge], candidates_[c], options_.gate);
        if (p >= 0.5) supported.push_back({p, static_cast<int>(c)});
      }
      std::sort(supported.begin(), supported.end(), std::greater<>());
      std::vector<int> more = matched->set;
      for (const auto& [p, c] : supported) {
        if (edge_used[candidates_[c].edge]) continue;
        more.push_back(c);
        edge_used[candidates_[c].edge] = true;
      }
      if (more.size() == matched->set.size()) break;
      MatchedSet next;
      if (!Solve(more, &next)) break;
      *matched = std::move(next);
    }
  }

  const ConstraintGraph& graph_;
  const Camera& camera_;
  const std::vector<cfuse::Factor>& constraints_;
  const FramePrior& prior_;
  const std::vector<EdgeModel>& edges_;
  const std::vector<EdgeCandidate>& candidates_;
  int dof_;
  MatchSearchOptions options_;
  std::vector<double> probability_;
  std::vector<std::vector<int>> rejected_;  // sorted candidate indices
  double estimation_ms_ = 0;
};

}  // namespace

bool SolveMatches(const std::vector<Factor>& constraints, const GaussianState& prior,
                  const std::vector<Factor>& matches, const std::vector<Block>& blocks, int dof,
                  double accept_confidence, MatchedSet* out, const std::vector<Factor>& also) {
  SequenceOptions sequence;
  sequence.gauss_newton_from_start = true;
  sequence.max_passes = 6;
  sequence.constraint_tolerance = 1e-9;
  std::vector<Factor> factors = constraints;
  factors.insert(factors.end(), also.begin(), also.end());
  factors.insert(factors.end(), matches.begin(), matches.end());
  out->state = prior;
  const SequenceSummary summary = FuseSequence(factors, &out->state, sequence);
  // Lowe's residual test: the matches' whitened residuals against a chi-square with the rows
  // the fit leaves free.
  double sum = 0, chi2 = 0;
  Eigen::VectorXd r;
  out->rows = 0;
  for (const Factor& f : matches) {
    EvaluateResidual(*f.residual, blocks, f.blocks, out->state.mean, &r, nullptr);
    sum += r.squaredNorm();
    chi2 += r.dot(f.noise.ldlt().solve(r));
    out->rows += static_cast<int>(r.size());
  }
  out->residual_sigma = std::sqrt(sum / std::max(1, out->rows));
  out->chi2 = chi2;
  return summary.converged && std::isfinite(chi2) &&
         chi2 <= ChiSquareQuantile(accept_confidence, std::max(1, out->rows - dof));
}

MatchSearchResult SearchMatchSets(const ConstraintGraph& graph, const Camera& camera,
                                  const std::vector<Factor>& constraints, const FramePrior& prior,
                                  const std::vector<EdgeModel>& edges,
                                  const std::vector<EdgeCandidate>& candidates, int dof,
                                  const MatchSearchOptions& options,
                                  const std::function<Judgement(MatchedSet*)>& judge) {
  return Search(graph, camera, constraints, prior, edges, candidates, dof, options).Run(judge);
}

}  // namespace cfuse
