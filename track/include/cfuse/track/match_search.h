// Which candidate lines are the model's edges: Lowe's best-first search over match sets
// (1992, §4), on the constraint kernel.
//
// A match set takes the most probable candidates (one per edge) until they constrain the
// model's DOF (2 rows each), and more while the product of their probabilities stays above
// 0.9. Each candidate taken is fused into a copy of the prior and the rest re-scored against
// the tightened prediction (`conditional_sets`), one path down Hel-Or & Werman's
// interpretation tree: once one edge of a box knocked 40 px sideways is matched, its parallel
// neighbours no longer look like the next edge's image. The set is solved from the prior with
// the model's constraints and passes when its whitened residual passes a chi-square test with
// the rows the fit leaves free (Lowe's residual test). A set that passes is extended with every
// candidate the tightened prediction supports (probability above one half), solved again, and
// judged by the caller (verification.h). A rejected or unverified set lowers each of its
// matches' probability by the factor (1 - 1/n) and is never tried again, nor any set containing
// it. The search ends at a set judged confident, when no untried set remains, or after the
// branch budget.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/track/edge_evidence.h"
#include "cfuse/track/edge_prediction.h"

namespace cfuse {

struct MatchSearchOptions {
  int max_branches = 5;              // match sets tried
  double accept_confidence = 0.999;  // of the residual's chi-square test
  double min_probability = 0.02;     // a candidate below is no candidate
  bool conditional_sets = true;
  double gate = 18.42;  // chi-square (2 rows) of a candidate from the tightened prediction
};

// A model edge's match: the measured image line.
struct MatchedLine {
  int edge = -1;  // index into ModelEdges()
  Eigen::Vector2d a, b;
};

struct MatchedSet {
  std::vector<int> set;  // candidate indices
  std::vector<MatchedLine> lines;
  GaussianState state;
  double residual_sigma = 0;  // px, RMS of the matches' residuals
  double chi2 = 0;
  int rows = 0;
  // px: the robust scale of the matches' residuals beyond their fits' own noise (what the model
  // and the camera get wrong), when the set was refined; 0 otherwise.
  double model_sigma = 0;
  // Depth samples fused (cfuse/track/depth_evidence.h) when the set was refined with a range
  // sensor's frame, and their robust scale (m).
  int depth_points = 0;
  double depth_sigma = 0;
};

// The caller's judgement of an extended set that passed (which it may refine in place): verified
// or not, a score (the best verified set wins), and whether it is good enough to end the search.
struct Judgement {
  bool verified = false;
  double score = 0;
  bool confident = false;
};

struct MatchSearchResult {
  std::optional<MatchedSet> best;  // the best verified set
  int branches = 0;                // sets tried
  double estimation_ms = 0;        // of the search's time, solving sets
};

// The frame's prior twice: `free`, each component about the prediction alone, from which sets
// are solved with the model's constraints (each fused once: a constraint fused twice into one
// direction leaves the covariance indefinite), and `constrained`, the same with the model's
// equalities fused, which predicts the edges (a lid moves with its box).
struct FramePrior {
  GaussianState free, constrained;
};

MatchSearchResult SearchMatchSets(const ConstraintGraph& graph, const Camera& camera,
                                  const std::vector<Factor>& constraints, const FramePrior& prior,
                                  const std::vector<EdgeModel>& edges,
                                  const std::vector<EdgeCandidate>& candidates, int dof,
                                  const MatchSearchOptions& options,
                                  const std::function<Judgement(MatchedSet*)>& judge);

// The set of `factors` (each an edge's match) solved from the free prior with the model's
// constraints and `also` (measurements of another kind: a range sensor's points, weighed by their
// own robust fit), and Lowe's residual test on the matches: false when it fails or the fusion does
// not converge. `set` is copied into the result as it is.
bool SolveMatches(const std::vector<Factor>& constraints, const GaussianState& prior,
                  const std::vector<Factor>& factors, const std::vector<Block>& blocks, int dof,
                  double accept_confidence, MatchedSet* out, const std::vector<Factor>& also = {});

}  // namespace cfuse
