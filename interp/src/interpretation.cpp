#include "cfuse/interp/interpretation.h"

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
#include "symmetric_readings.h"

namespace cfuse {

const char* StatusName(SearchStats::Status status) {
  switch (status) {
    case SearchStats::Status::kComplete:
      return "complete";
    case SearchStats::Status::kBudget:
      return "node budget exhausted";
  }
  return "?";
}

namespace {

constexpr double kTwoPi = 6.283185307179586;
// Seed sets tried per model (rigid triangles, or feature triples per rigid component).
constexpr int kMaxSeedSets = 6;
// P3P solutions computed in all, for image data; beyond it seed generation stops.
constexpr long kMaxP3pCalls = 200000;
// A later seed is searched when its support (model points with a measurement near their
// seeded place) is at least the matches found so far less this: support counts points at the
// nominal articulation, so a seed's interpretation can match a few more.
constexpr int kSupportMargin = 2;
// Of a point's unit constraint gradients, the smallest singular value that determines it.
constexpr double kDetermined = 0.1;
constexpr int kPlaceIterations = 30;
constexpr double kConfident = 0.99;
// An interpretation leaving at most this many model points unmatched ends the opening of
// further seed sets (Explore).
constexpr int kLazyNulls = 2;
// Samples of a joint's sweep (Support) at most: a whole turn of a 120 mm blade within a 190 mm
// model takes about 130. Fewer for image data (Support).
constexpr int kMaxSweepSamples = 360;
constexpr size_t kMaxImageSweepSamples = 90;
// Labellings with a measurement shifted to an unmatched point of its component, per round,
// the likeliest first.
constexpr size_t kMaxShifts = 8;
// Image data: the fewest matches predicted before they were seen that an answer needs
// (Interpretation::Refusal).
constexpr int kMinPredicted = 3;

// A model point of the plan: a level's component and feature.
struct ModelPointRef {
  int component = -1, feature = -1;
};

Eigen::Vector3d NominalWorld(const ConstraintGraph& g, ModelPointRef p) {
  return ModelPoint(g, g.nominal, p.component, p.feature);
}

// The measurement function of model point `p` against measurement `m`, or with a zero
// measurement (`m` < 0) for predictions: a 3D point, or an image point when `image`.
Factor MeasurementFactor(const ConstraintGraph& g, const MeasurementSet& set, ModelPointRef p,
                         int m, bool image) {
  const Component& comp = g.components[p.component];
  const Eigen::Vector3d position =
      comp.rigid ? comp.points[p.feature].position : Eigen::Vector3d::Zero();
  std::shared_ptr<const ResidualFunction> f;
  Eigen::MatrixXd noise;
  if (!image) {
    const Eigen::Vector3d z = m >= 0 ? set.points[m].xyz : Eigen::Vector3d::Zero();
    f = comp.rigid ? std::make_shared<Point3Residual>(position, z)
                   : std::make_shared<Point3Residual>(z);
    if (m >= 0) noise = set.points[m].cov3;
  } else {
    const Eigen::Vector2d z = m >= 0 ? set.points[m].uv : Eigen::Vector2d::Zero();
    f = comp.rigid ? std::make_shared<ImagePointResidual>(*set.camera, position, z)
                   : std::make_shared<ImagePointResidual>(*set.camera, z);
    if (m >= 0) noise = set.points[m].cov2;
  }
  return {f,
          {comp.block},
          noise,
          fmt::format("measurement {} of {}", m, ModelPointName(g, p.component, p.feature))};
}

// A candidate for a level: a measurement (or -1, the null branch) with its δ and Lowe's
// probability p/(p+q).
struct Candidate {
  int measurement = -1;
  double delta = 0;
  double probability = 0;
  bool informative = false;  // its gate holds less than one clutter point on average
  double log_ratio = 0;      // log(p / q): how much likelier the point than clutter
};

// A node of the depth-first search whose children are being tried.
struct Frame {
  int level = 0;
  GaussianState state;  // ready to predict `level`: its constraints fused
  std::vector<Candidate> candidates;
  size_t next = 0;
  int matched = 0;
  int nulls = 0;                  // null branches taken above by choice (not forced)
  bool confident_passed = false;  // one of them with p/(p+q) >= kConfident
  // The level's point is blind: every constraint that would place it touches an occluded
  // point, so nothing predicts it (see BuildCandidates). It is postponed to the end of the
  // branch (or, met again there, left unmatched); this null branch is not counted.
  bool blind = false;
  // No measurement near a prediction sharp enough to expect none there by chance: evidence
  // that the point is occluded. Such nulls are free on a branch, up to
  // InterpretOptions::free_evidenced_nulls.
  bool evidenced_null = false;
  int free_nulls = 0;         // taken above
  double gate = 0;            // on a match's total δ at this level
  std::vector<int> pending;   // plan levels still to visit after this one, in order
  std::vector<char> done;     // per plan level: visited (matched or null) on this branch
  std::vector<char> revisit;  // per plan level: postponed once, to be visited again
  double delta_sum = 0;
  double nis_sum = 0;  // every δ and constraint NIS on the branch (joint compatibility)
  int nis_dof = 0;
  std::vector<std::pair<int, double>> best3;  // for the trace
  std::vector<int> own;  // the level's constraints on its component, fused after the match
  // Single points taken as occluded (null), and the constraints on them not yet fused: fused
  // where such a point is guessed to be, they would pin it wrongly along any freedom its
  // matched neighbours leave (a joint's angle), so they wait until it can be placed.
  std::vector<bool> null_component;
  std::vector<int> deferred;
  std::vector<int> tried;  // per component: ready constraints when its placing was last tried
};

// A fusion plan and what the search needs of it.
struct Context {
  FusionPlan plan;
  std::vector<ModelPointRef> points;     // per level
  std::vector<double> level_gate;        // per level: the gate on a match's total δ
  std::vector<Eigen::Vector3d> nominal;  // per level: the point in the nominal geometry
};

// A seed hypothesis: measurements for some plan levels, and the pose they give the model.
struct Seed {
  int context = -1;                             // the plan it starts (Interpreter::contexts_)
  std::vector<std::pair<int, int>> assignment;  // (plan level, measurement)
  Rigid3d world_from_nominal;
  int support = 0;      // model points with a measurement near their seeded position
  // At most this many points can match below the seed: its own component's supported points,
  // those of each component joined to it that its joint's sweep brings near a measurement,
  // and every point of the others, whose places the seed does not fix (Support).
  int bound = 0;
  // Per component: where the search starts it, as a motion of the nominal geometry (the seed's
  // pose, and for components beyond joints the best of each joint's sweep: Support).
  std::vector<Rigid3d> placement;
  double residual = 0;  // of the seed's own geometry, normalised
};

// Measurements binned on a uniform grid over their bounding box, for "is there one within r
// of x" queries (r at most a cell): the 27 (or 9) cells around x, each a contiguous run.
class Grid {
 public:
  Grid(double cell, int dims, const std::vector<std::pair<Eigen::Vector3d, int>>& points)
      : cell_(cell), dims_(dims) {
    Eigen::AlignedBox3d box;
    for (const auto& [x, id] : points) box.extend(x);
    origin_ = box.isEmpty() ? Eigen::Vector3d::Zero() : box.min();
    const Eigen::Vector3d sizes =
        box.isEmpty() ? Eigen::Vector3d(Eigen::Vector3d::Zero()) : Eigen::Vector3d(box.sizes());
    for (int a = 0; a < 3; ++a) {
      // At most 64 cells a side: a finer grid only costs memory.
      cells_[a] = std::clamp(static_cast<int>(sizes[a] / cell_) + 1, 1, 64);
      size_[a] = std::max(cell_, sizes[a] / cells_[a] + 1e-12);
    }
    std::vector<std::vector<std::pair<Eigen::Vector3d, int>>> bins(static_cast<size_t>(cells_[0]) *
                                                                   cells_[1] * cells_[2]);
    for (const auto& p : points) bins[Index(Cell(p.first))].push_back(p);
    start_.push_back(0);
    for (const auto& bin : bins) {
      entries_.insert(entries_.end(), bin.begin(), bin.end());
      start_.push_back(static_cast<int>(entries_.size()));
    }
  }
  // Whether a point not in `exclude` lies within r (<= a cell) of x.
  bool AnyWithin(const Eigen::Vector3d& x, double r, const std::vector<int>& exclude) const {
    const Eigen::Vector3i c = Cell(x);
    const int dz = dims_ == 3 ? 1 : 0;
    for (int i = std::max(c.x() - 1, 0); i <= std::min(c.x() + 1, cells_[0] - 1); ++i) {
      for (int j = std::max(c.y() - 1, 0); j <= std::min(c.y() + 1, cells_[1] - 1); ++j) {
        for (int k = std::max(c.z() - dz, 0); k <= std::min(c.z() + dz, cells_[2] - 1); ++k) {
          const size_t b = Index({i, j, k});
          for (int e = start_[b]; e < start_[b + 1]; ++e) {
            const auto& [y, id] = entries_[e];
            if ((y - x).squaredNorm() <= r * r &&
                std::find(exclude.begin(), exclude.end(), id) == exclude.end()) {
              return true;
            }
          }
        }
      }
    }
    return false;
  }

 private:
  // The cell of x, clamped to the grid (a point outside is at least as far from every
  // measurement as the border cell's neighbours are).
  Eigen::Vector3i Cell(const Eigen::Vector3d& x) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      const double v = std::floor((x[a] - origin_[a]) / size_[a]);
      c[a] = static_cast<int>(std::clamp(v, -1.0, static_cast<double>(cells_[a])));
    }
    return c;
  }
  size_t Index(const Eigen::Vector3i& c) const {
    return (static_cast<size_t>(std::clamp(c.z(), 0, cells_[2] - 1)) * cells_[1] +
            std::clamp(c.y(), 0, cells_[1] - 1)) *
               cells_[0] +
           std::clamp(c.x(), 0, cells_[0] - 1);
  }
  double cell_;
  int dims_;
  Eigen::Vector3d origin_;
  std::array<int, 3> cells_{1, 1, 1};
  Eigen::Vector3d size_;
  std::vector<std::pair<Eigen::Vector3d, int>> entries_;  // bin by bin
  std::vector<int> start_;                                // per bin: its first entry
};

double LargestVariance(const Eigen::MatrixXd& cov) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(cov, Eigen::EigenvaluesOnly)
      .eigenvalues()
      .maxCoeff();
}

// The median of the 3D measurements' largest standard deviations (0 without any).
double TypicalNoise(const MeasurementSet& set) {
  std::vector<double> sigmas;
  for (const MeasuredPoint& m : set.points) {
    if (m.is_3d) sigmas.push_back(std::sqrt(std::max(0.0, LargestVariance(m.cov3))));
  }
  if (sigmas.empty()) return 0;
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  return sigmas[sigmas.size() / 2];
}

class Interpreter {
 public:
  Interpreter(const ConstraintGraph& g, const MeasurementSet& set, const InterpretOptions& options,
              std::vector<bool> use)
      : g_(g),
        set_(set),
        options_(options),
        use_(std::move(use)),
        symmetries_(g, 3 * TypicalNoise(set)) {
    extent_ = ModelExtent(g);
    Eigen::AlignedBox3d box3;
    Eigen::AlignedBox2d box2;
    // A measurement repeated exactly (same point, same covariance) is one observation: only its
    // first copy takes part, so copies do not double the branching of every level.
    duplicate_.assign(set.points.size(), false);
    std::map<std::vector<double>, int> seen;
    for (size_t i = 0; i < set.points.size(); ++i) {
      const MeasuredPoint& m = set.points[i];
      std::vector<double> key = {m.is_3d ? 1.0 : 0.0};
      if (m.is_3d) {
        key.insert(key.end(), m.xyz.data(), m.xyz.data() + 3);
        key.insert(key.end(), m.cov3.data(), m.cov3.data() + 9);
      } else {
        key.insert(key.end(), m.uv.data(), m.uv.data() + 2);
        key.insert(key.end(), m.cov2.data(), m.cov2.data() + 4);
      }
      if (!seen.emplace(std::move(key), static_cast<int>(i)).second) {
        duplicate_[i] = true;
        continue;
      }
      if (m.is_3d) {
        box3.extend(m.xyz);
        index3_.push_back(static_cast<int>(i));
      } else {
        box2.extend(m.uv);
        index2_.push_back(static_cast<int>(i));
      }
    }
    // Lowe's clutter density q: measurements per volume of their bounding box (3D), per image
    // area (2D; the points' bounding box when the camera's size is unknown).
    if (!index3_.empty()) {
      clutter3_ = index3_.size() / box3.sizes().cwiseMax(0.1 * extent_).prod();
    }
    if (!index2_.empty()) {
      double area = box2.sizes().cwiseMax(1.0).prod();
      if (set.camera && set.camera->width > 0 && set.camera->height > 0) {
        area = static_cast<double>(set.camera->width) * set.camera->height;
      }
      clutter2_ = index2_.size() / area;
    }
    gate3_ = Gate(3);
    gate2_ = Gate(2);
    for (const Constraint& c : g.constraints) {
      constraint_components_.push_back(ConstraintComponents(g, c));
    }
    image_ = index3_.empty() && !index2_.empty();
    for (const Block& b : g.blocks) block_kinds_.push_back(b.kind);
    contexts_.push_back(MakeContext(Plan(nullptr)));
    levels_ = static_cast<int>(contexts_[0].plan.levels.size());
  }

  const FusionPlan& best_plan() const { return contexts_[best_context_].plan; }
  bool image() const { return image_; }

  // The estimate from a labelling of the best plan's levels, started at `start` (the tree's
  // estimate, which has every point, occluded ones included, near its place; the closed-form
  // starts of solve.h place occluded points of a moved part at the nominal geometry).
  Solution SolveLabelling(const std::vector<int>& assignment, const Values& start) const {
    Solution solution = SolveFrom(assignment, &start);
    if (!solution.summary.converged) {
      // Gauss-Newton from the tree's estimate can still run away where an occluded point sits
      // only roughly placed; solve.h's closed-form starts are the fallback, and the better
      // of the two (converged, else the smaller constraint residual) is kept.
      Solution cold = SolveFrom(assignment, nullptr);
      if (cold.summary.converged ||
          cold.summary.max_constraint_residual < solution.summary.max_constraint_residual) {
        solution = std::move(cold);
      }
    }
    return solution;
  }

  // The same from `start`, or from solve.h's own starts when null.
  Solution SolveFrom(const std::vector<int>& assignment, const Values* start) const {
    PoseSet guess;
    SolveOptions options = options_.solve;
    if (start) {
      for (const Component& c : g_.components) {
        const Block& b = g_.blocks[c.block];
        if (c.rigid) {
          guess.components.push_back({c.name, start->poses[b.index], {}});
        } else {
          guess.points.push_back({c.name, start->points[b.index], {}});
        }
      }
      options.guess = &guess;
      options.sequence.gauss_newton_from_start = true;
    }
    MeasurementSet labelled = set_;
    for (MeasuredPoint& m : labelled.points) m.label.clear();
    const Context& ctx = contexts_[best_context_];
    for (int l = 0; l < levels_; ++l) {
      if (assignment[l] >= 0) {
        labelled.points[assignment[l]].label =
            ModelPointName(g_, ctx.points[l].component, ctx.points[l].feature);
      }
    }
    return Solve(g_, labelled, options);
  }

  // Refines the best labelling against its own estimate (see "Refinement" below), at most
  // `rounds` times; returns the estimate of the final labelling and the number of changes.
  Solution Refine(std::vector<int>* assignment, int rounds, int* changes) const {
    Solution solution = SolveLabelling(*assignment, best_mean_);
    *changes = 0;
    // Scores under an estimate that did not converge mean nothing: the labelling stays.
    if (!solution.summary.converged) return solution;
    double score = LabellingScore(best_context_, *assignment, solution.state);
    // Each labelling is scored under its own estimate: the likelihood ratio of the data under
    // it against all clutter. A proposal replaces the labelling when it scores higher.
    // A proposal is also scored after one re-association under its own estimate: a label
    // moved to the right point frees the points it blocked (a segment matched twisted about
    // its long axis scores better only once its other corners follow).
    auto try_labelling = [&](const std::vector<int>& proposal) {
      std::vector<int> next = proposal;
      Solution next_solution = SolveLabelling(next, solution.state.mean);
      if (!next_solution.summary.converged) return false;
      double next_score = LabellingScore(best_context_, next, next_solution.state);
      if (std::vector<int> followed = Reassociate(best_context_, next_solution.state);
          followed != next) {
        Solution followed_solution = SolveLabelling(followed, next_solution.state.mean);
        const double followed_score =
            followed_solution.summary.converged
                ? LabellingScore(best_context_, followed, followed_solution.state)
                : -HUGE_VAL;
        if (followed_score > next_score) {
          next = std::move(followed);
          next_solution = std::move(followed_solution);
          next_score = followed_score;
        }
      }
      if (!(next_score > score)) return false;
      *assignment = next;
      solution = std::move(next_solution);
      score = next_score;
      ++*changes;
      return true;
    };
    for (int r = 0; r < rounds; ++r) {
      // Every point re-associated at once.
      const std::vector<int> next = Reassociate(best_context_, solution.state);
      if (next != *assignment && try_labelling(next)) continue;
      // A measurement moved from a matched point to an unmatched one whose gate holds it: two
      // points close together (the two faces of a thin plate) of which one is occluded. Matched
      // to the wrong one, the estimate bends to fit it, and re-association alone stays there.
      if (MoveToUnmatched(try_labelling, solution.state, *assignment)) continue;
      // A corner matched to its neighbour across a narrow part, the neighbour unmatched: the
      // estimate twists the part to fit, which keeps the corner's own measurement out of
      // every gate. The measurement moved to the neighbour, the part untwists and
      // re-association under it finds the corner.
      if (ShiftToUnmatched(try_labelling, solution.state, *assignment)) continue;
      // Image data: two matched points close together, each inside the other's gate (a thin
      // plate's two faces seen nearly edge-on): a labelling swapped there bends its estimate to
      // fit, and re-association under that estimate keeps it. Each such pair swapped, under
      // its own estimate. (In 3D such pairs are rare and the predictions cost 1.5 % of the
      // lamp's time.)
      if (!image_ || !SwapClosePairs(try_labelling, solution.state, *assignment)) break;
    }
    return solution;
  }

  template <typename Try>
  bool SwapClosePairs(Try& try_labelling, const GaussianState& state,
                      const std::vector<int>& assignment) const {
    const Context& ctx = contexts_[best_context_];
    std::vector<std::pair<Prediction, Prediction>> predicted(levels_);
    for (int l = 0; l < levels_; ++l) {
      if (assignment[l] >= 0) predicted[l] = PredictPoint(ctx.points[l], state);
    }
    auto inside = [&](int level, int m) {
      const auto& [p3, p2] = predicted[level];
      return Score(set_.points[m].is_3d ? p3 : p2, m).has_value();
    };
    bool changed = false;
    std::vector<int> current = assignment;
    for (int i = 0; i < levels_; ++i) {
      for (int j = i + 1; j < levels_; ++j) {
        const int mi = current[i], mj = current[j];
        if (mi < 0 || mj < 0 || !inside(i, mj) || !inside(j, mi)) continue;
        std::vector<int> next = current;
        std::swap(next[i], next[j]);
        if (try_labelling(next)) {
          current = std::move(next);
          changed = true;
        }
      }
    }
    return changed;
  }

  template <typename Try>
  bool ShiftToUnmatched(Try& try_labelling, const GaussianState& state,
                        const std::vector<int>& assignment) const {
    // 3D data only: in an image, points far apart in depth project close together, and such
    // shifts turned refusals into wrong answers (scissors from one camera: 2 more of 50).
    if (image_) return false;
    const Context& ctx = contexts_[best_context_];
    std::vector<Prediction> predicted(levels_);
    for (int l = 0; l < levels_; ++l) predicted[l] = PredictPoint(ctx.points[l], state).first;
    // (how near the measurement is to the unmatched point over the two points' distance,
    // unmatched level, matched level)
    std::vector<std::tuple<double, int, int>> shifts;
    for (int n = 0; n < levels_; ++n) {
      if (assignment[n] >= 0 || !predicted[n].valid) continue;
      for (int j = 0; j < levels_; ++j) {
        const int m = assignment[j];
        if (m < 0 || ctx.points[j].component != ctx.points[n].component) continue;
        if (!set_.points[m].is_3d || !predicted[j].valid) continue;
        const double apart = (predicted[n].mean - predicted[j].mean).norm();
        const double ratio = (set_.points[m].xyz - predicted[n].mean).norm() / apart;
        // Nearer the unmatched point than twice the two points' distance: it may be that
        // point's measurement, the estimate bent towards the other.
        if (ratio < 2) shifts.emplace_back(ratio, n, j);
      }
    }
    std::sort(shifts.begin(), shifts.end());
    if (shifts.size() > kMaxShifts) shifts.resize(kMaxShifts);
    for (const auto& [ratio, n, j] : shifts) {
      std::vector<int> next = assignment;
      next[n] = next[j];
      next[j] = -1;
      if (try_labelling(next)) return true;
    }
    return false;
  }

  template <typename Try>
  bool MoveToUnmatched(Try& try_labelling, const GaussianState& state,
                       const std::vector<int>& assignment) const {
    const Context& ctx = contexts_[best_context_];
    for (int n = 0; n < levels_; ++n) {
      if (assignment[n] >= 0) continue;
      const auto [p3, p2] = PredictPoint(ctx.points[n], state);
      for (int j = 0; j < levels_; ++j) {
        const int m = assignment[j];
        if (m < 0 || !Score(set_.points[m].is_3d ? p3 : p2, m)) continue;
        std::vector<int> next = assignment;
        next[n] = m;
        next[j] = -1;
        if (try_labelling(next)) return true;
      }
    }
    return false;
  }

  // Other interpretations as complete as the answer: seeds about as well supported as the
  // answer's own that place the model elsewhere (a symmetric part turned onto itself, identical
  // parts exchanged) are searched for labellings matching as many points; each found is
  // returned with its estimate when the fit test does not reject it and it is a distinct
  // answer. At most `max_seeds` such seeds are searched, within what is left of the budget.
  struct Found {
    Solution solution;
    bool same_plan = false;  // its assignment follows the answer's plan levels
    std::vector<int> assignment;
  };
  std::vector<Found> Alternatives(const GaussianState& answer, int max_seeds) {
    std::vector<Found> out;
    if (best_matched_ < 0 || seeds_.empty()) return out;
    const int need = best_matched_;
    const int saved_context = best_context_, saved_support = best_seed_support_;
    const double saved_delta = best_delta_;
    const std::vector<int> saved_assignment = best_assignment_;
    const Values saved_mean = best_mean_;
    const auto saved_trace = best_trace_;
    const int saved_predicted = best_predicted_;
    const SearchStats::Status saved_status = stats_.status;
    stats_.status = SearchStats::Status::kComplete;  // the searches below set it anew
    std::vector<GaussianState> placed = {answer};  // the answer's and each alternative's
    // Whether the seed puts its own points where one of `placed` has them.
    auto known = [&](const Seed& seed) {
      const Context& ctx = contexts_[seed.context];
      return std::any_of(placed.begin(), placed.end(), [&](const GaussianState& state) {
        for (const auto& [level, m] : seed.assignment) {
          const Eigen::Vector3d seeded = seed.world_from_nominal * ctx.nominal[level];
          const Eigen::Vector3d there =
              ModelPoint(g_, state.mean, ctx.points[level].component, ctx.points[level].feature);
          if ((there - seeded).norm() > 0.05 * extent_) {
            return false;
          }
        }
        return true;
      });
    };
    std::vector<size_t> order(seeds_.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return seeds_[a].support > seeds_[b].support;
    });
    int tried = 0;
    for (size_t i : order) {
      if (tried >= max_seeds || seeds_[i].support + kSupportMargin < saved_support) break;
      // A seed searched while a better interpretation stood was asked for more matches than
      // `need`, and may hold one with as many; one searched before found fewer.
      const bool asked_more = i < searched_beyond_.size() && searched_beyond_[i] >= need;
      if ((searched_[i] && !asked_more) || known(seeds_[i])) continue;
      // Within what is left of the budget (none after a search the budget ended); a seed's own
      // matches are fused before the search can stop on it.
      if (stats_.nodes + static_cast<long>(seeds_[i].assignment.size()) >= options_.max_nodes) {
        break;
      }
      searched_[i] = true;
      ++tried;
      best_matched_ = need - 1;  // the search below takes only labellings matching `need`
      found_ = false;
      Search(&seeds_[i]);
      if (stats_.status == SearchStats::Status::kBudget) break;
      if (!found_) continue;
      Solution alternative = SolveLabelling(best_assignment_, best_mean_);
      if (!alternative.accepted()) continue;
      if (!Distinct(g_, alternative.state.mean, answer, extent_)) continue;
      placed.push_back(alternative.state);
      out.push_back({std::move(alternative), best_context_ == saved_context, best_assignment_});
    }
    best_matched_ = need;
    best_context_ = saved_context;
    best_seed_support_ = saved_support;
    best_delta_ = saved_delta;
    best_assignment_ = saved_assignment;
    best_mean_ = saved_mean;
    best_trace_ = saved_trace;
    best_predicted_ = saved_predicted;
    stats_.status = saved_status;
    return out;
  }

  // The answer read by the model's symmetries (symmetric_readings.h): the same points with
  // congruent parts exchanged or a symmetric part turned onto itself. Each reading's labelling
  // is re-fitted from the reading, and returned, as Alternatives does, when its estimate is
  // accepted and distinct from the answer. Readings whose constraints are broken by more than
  // 2 % of the model's size (or 0.02 rad) are not tried: no re-fit repairs that much.
  std::vector<Found> SymmetricAlternatives(const Solution& answer,
                                           const std::vector<int>& assignment,
                                           int max_readings) const {
    std::vector<Found> out;
    if (!symmetries_.any()) return out;
    const Context& ctx = contexts_[best_context_];
    std::map<std::pair<int, int>, int> level_of;
    for (int l = 0; l < levels_; ++l) {
      level_of[{ctx.points[l].component, ctx.points[l].feature}] = l;
    }
    const double tolerance = 0.02 * std::max(extent_, 1.0);
    for (const Reading& reading : symmetries_.Find(answer.state.mean, tolerance, max_readings)) {
      std::vector<int> next(levels_, -1);
      for (int l = 0; l < levels_; ++l) {
        const ModelPointRef p = ctx.points[l];
        const int source = reading.source_component[p.component];
        const int feature =
            g_.components[p.component].rigid ? reading.source_point[p.component][p.feature]
                                             : p.feature;
        const auto it = level_of.find({source, feature});
        if (it != level_of.end()) next[l] = assignment[it->second];
      }
      Solution solution = SolveLabelling(next, reading.mean);
      if (!solution.accepted() || !Distinct(g_, solution.state.mean, answer.state, extent_)) {
        continue;
      }
      out.push_back({std::move(solution), true, std::move(next)});
    }
    return out;
  }

  // Searches below each seed, most supported first, by iterative deepening on null branches:
  // round k allows k of them, and the first complete interpretation found below a seed ends
  // its search (it has the most matches that seed allows: every round before failed). A later
  // seed is searched only if its support could still beat that interpretation, and must then
  // match more points. Without seeds, the same from the nominal geometry (the paper's search).
  void Run() {
    Explore();
    complete_ = best_matched_ >= 0;
    if (best_matched_ < 0 && partial_.matched > 0) {
      // The budget ended the search before a complete interpretation: the branch that matched
      // most, its remaining levels taken as unmatched.
      best_matched_ = partial_.matched;
      best_context_ = partial_.context;
      best_seed_support_ = partial_.support;
      best_assignment_ = partial_.assignment;
      best_mean_ = partial_.mean;
      best_predicted_ = -1;
      best_trace_.assign(levels_, {});
    }
  }

  // Seed sets are opened one at a time (each costs its measurement triples), and a set's clear
  // winner (support of at least 4 points, or a sixth of them, and 2 more than the set's next
  // seed; a seed from clutter finds 0-2) is searched at once; once an interpretation with at
  // most kLazyNulls unmatched points is found, no further set is opened. Otherwise every seed
  // of every set competes, most supported first, as above.
  void Explore() {
    const bool image = image_;
    if (image && (!set_.camera || set_.camera->model != Camera::Model::kPinhole ||
                  !options_.poses_from_three_projections)) {
      Search(nullptr);  // no P3P solver for this camera: the unseeded search
      return;
    }
    std::vector<Seed>& seeds = seeds_;
    std::vector<bool>& searched = searched_;
    auto by_support = [](const Seed& a, const Seed& b) {
      return a.support > b.support || (a.support == b.support && a.residual < b.residual);
    };
    auto search = [&](size_t i) {
      searched[i] = true;
      searched_beyond_.resize(seeds.size(), -1);
      searched_beyond_[i] = best_matched_;
      ++stats_.seeds_tried;
      found_ = false;
      seed_support_ = seeds[i].support;
      Search(&seeds[i]);
      return stats_.status != SearchStats::Status::kBudget;
    };
    const int strong = std::max(4, levels_ / 6);
    for (const std::vector<ModelPointRef>& s : SeedSets(image)) {
      const size_t first = seeds.size();
      Seeds(s, &seeds);
      stats_.seeds = static_cast<int>(seeds.size());  // also when the budget ends the search
      searched.resize(seeds.size(), false);
      std::stable_sort(seeds.begin() + static_cast<long>(first), seeds.end(), by_support);
      // A clear winner: well supported, and by two points more than the set's next seed.
      if (seeds.size() > first && seeds[first].support >= strong &&
          (seeds.size() == first + 1 || seeds[first].support >= seeds[first + 1].support + 2) &&
          (best_matched_ < 0 || seeds[first].bound + kSupportMargin >= best_matched_)) {
        if (!search(first)) return;
      }
      if (best_matched_ >= levels_ - kLazyNulls) break;
    }
    stats_.seeds = static_cast<int>(seeds.size());
    if (seeds.empty()) {
      Search(nullptr);
      return;
    }
    std::vector<size_t> order(seeds.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return by_support(seeds[a], seeds[b]); });
    for (size_t i : order) {
      if (searched[i]) continue;
      if (best_matched_ >= 0 && seeds[i].bound + kSupportMargin < best_matched_) continue;
      if (!search(i)) return;
    }
  }

  SearchStats stats_;
  bool complete_ = false;  // a complete interpretation was found (not only a partial branch)
  int best_matched_ = -1;
  double best_delta_ = 0;
  std::vector<int> best_assignment_;
  Values best_mean_;  // the tree's estimate at the best leaf
  std::vector<std::vector<std::pair<int, double>>> best_trace_;
  int best_predicted_ = -1;  // SearchStats::predicted of the best leaf (-1: a partial branch)

 private:
  // The fusion plan from `start` (null: the automatic start), from the cache when given one.
  FusionPlan Plan(const PlanStart* start) const {
    const bool image = !index2_.empty();
    const auto make = [&] { return PlanFusion(g_, image, start); };
    if (!options_.plans) return make();
    CFUSE_CHECK_MSG(&options_.plans->graph() == &g_, "a plan cache of another model");
    return options_.plans->Plan(image, start, make);
  }

  Context MakeContext(FusionPlan plan) const {
    Context c;
    c.plan = std::move(plan);
    for (const PlanLevel& l : c.plan.levels) {
      c.points.push_back({l.component, l.feature});
      c.nominal.push_back(NominalWorld(g_, c.points.back()));
      // A match's δ (its NIS plus that of the constraints placing it) is gated at the
      // chi-square quantile for the measurement's rows and those constraints' rows.
      int rows = image_ ? 2 : 3;
      for (int k : l.constraints) {
        const std::vector<int>& comps = constraint_components_[k];
        if (use_[k] && std::find(comps.begin(), comps.end(), l.component) != comps.end()) {
          rows += g_.constraints[k].residual->dimension();
        }
      }
      c.level_gate.push_back(Gate(rows));
    }
    return c;
  }

  // The context whose plan starts with seed set `s`.
  int ContextFor(const std::vector<ModelPointRef>& s) {
    PlanStart start;
    if (g_.components[s[0].component].rigid) {
      start.components = {s[0].component};
      for (ModelPointRef p : s) start.features.push_back(p.feature);
    } else {
      for (ModelPointRef p : s) start.components.push_back(p.component);
    }
    Context c = MakeContext(Plan(&start));
    // The seed set must open the plan, in order (a triangle's order is the plan's).
    if (c.plan.seed_levels != static_cast<int>(s.size())) return -1;
    contexts_.push_back(std::move(c));
    return static_cast<int>(contexts_.size()) - 1;
  }

  // ---- Seeds ------------------------------------------------------------------------------

  // Sets of plan levels from which a pose follows in closed form: up to kMaxSeedSets rigid
  // triangles of single points (best smallest side first, each point in at most two), and per
  // rigid component its best-spread feature triples (with a fourth feature for image data).
  std::vector<std::vector<ModelPointRef>> SeedSets(bool image) const {
    std::vector<std::vector<ModelPointRef>> sets;
    for (size_t c = 0; c < g_.components.size(); ++c) {
      const Component& comp = g_.components[c];
      if (!comp.rigid || comp.points.size() < (image ? 4u : 3u)) continue;
      const int n = static_cast<int>(comp.points.size());
      std::vector<std::tuple<double, int, int, int>> triples;
      for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j)
          for (int k = j + 1; k < n; ++k) {
            const auto& p = comp.points;
            const double area =
                (p[j].position - p[i].position).cross(p[k].position - p[i].position).norm();
            if (area > 1e-12) triples.push_back({-area, i, j, k});
          }
      std::sort(triples.begin(), triples.end());
      std::vector<int> uses(n, 0);
      int taken = 0;
      for (const auto& [area, i, j, k] : triples) {
        if (taken == kMaxSeedSets) break;
        if (uses[i] >= 2 || uses[j] >= 2 || uses[k] >= 2) continue;
        std::vector<ModelPointRef> set = {
            {static_cast<int>(c), i}, {static_cast<int>(c), j}, {static_cast<int>(c), k}};
        if (image) {
          const auto& p = comp.points;
          const Eigen::Vector3d normal =
              (p[j].position - p[i].position).cross(p[k].position - p[i].position).normalized();
          int fourth = -1;
          double far = 1e-9 * extent_;
          for (int l = 0; l < n; ++l) {
            if (l == i || l == j || l == k) continue;
            const double d = std::abs(normal.dot(p[l].position - p[i].position));
            if (d > far) {
              far = d;
              fourth = l;
            }
          }
          if (fourth < 0) continue;  // a planar component: P3P's fourth check needs depth
          set.push_back({static_cast<int>(c), fourth});
        }
        for (int x : {i, j, k}) ++uses[x];
        sets.push_back(set);
        ++taken;
      }
    }
    if (!image) {
      for (const std::array<int, 3>& t : SeedTriangles()) {
        sets.push_back({{t[0], -1}, {t[1], -1}, {t[2], -1}});
      }
    }
    return sets;
  }

  // Up to kMaxSeedSets rigid triangles (schedule.h), best-shaped first, each point in at most
  // two of them, so that one occluded point does not take every seed set with it.
  std::vector<std::array<int, 3>> SeedTriangles() const {
    std::vector<std::array<int, 3>> out;
    std::vector<int> uses(g_.components.size(), 0);
    const auto make = [&] { return RigidTriangles(g_, &use_); };
    const std::vector<std::array<int, 3>> triangles =
        options_.plans
            ? options_.plans->Triangles(options_.use_constraints_between_components, make)
            : make();
    for (const std::array<int, 3>& t : triangles) {
      if (static_cast<int>(out.size()) == kMaxSeedSets) break;
      if (uses[t[0]] >= 2 || uses[t[1]] >= 2 || uses[t[2]] >= 2) continue;
      for (int x : t) ++uses[x];
      out.push_back(t);
    }
    return out;
  }

  // Hypotheses for every seed set, most supported first.
  // Appends the hypotheses of seed set `s`.
  void Seeds(const std::vector<ModelPointRef>& s, std::vector<Seed>* seeds) {
    const int context = ContextFor(s);
    if (context < 0) return;
    // The seed set in the plan's order (a triangle may open in another order).
    std::vector<ModelPointRef> ordered;
    for (int l = 0; l < static_cast<int>(s.size()); ++l) {
      ordered.push_back(contexts_[context].points[l]);
    }
    if (image_) {
      ImageSeeds(ordered, context, seeds);
    } else {
      PointSeeds(ordered, context, seeds);
    }
  }

  // 3D: measurement triples whose pairwise distances match the seed's within the gate.
  void PointSeeds(const std::vector<ModelPointRef>& s, int context,
                  std::vector<Seed>* seeds) const {
    const double k = std::sqrt(Gate(1));
    std::array<Eigen::Vector3d, 3> model;
    for (int i = 0; i < 3; ++i) model[i] = NominalWorld(g_, s[i]);
    const double d01 = (model[0] - model[1]).norm(), d12 = (model[1] - model[2]).norm(),
                 d02 = (model[0] - model[2]).norm();
    const int n = static_cast<int>(index3_.size());
    auto x = [&](int i) -> const Eigen::Vector3d& { return set_.points[index3_[i]].xyz; };
    if (distance_.rows() != n) {
      // Shared by every seed set: the measurements' largest variances and pairwise distances.
      sigma2_.resize(n);
      for (int i = 0; i < n; ++i) sigma2_[i] = LargestVariance(set_.points[index3_[i]].cov3);
      distance_.resize(n, n);
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) distance_(i, j) = (x(i) - x(j)).norm();
    }
    auto fits = [&](int i, int j, double d, double* r2) {
      const double e = distance_(i, j) - d, var = sigma2_[i] + sigma2_[j];
      *r2 += e * e / var;
      return e * e <= k * k * var;
    };
    // Pairs for the seed's first side, then its third point against both.
    std::vector<std::vector<int>> near12(n);
    for (int j = 0; j < n; ++j) {
      for (int l = 0; l < n; ++l) {
        double r = 0;
        if (l != j && fits(j, l, d12, &r)) near12[j].push_back(l);
      }
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        double r01 = 0;
        if (j == i || !fits(i, j, d01, &r01)) continue;
        for (int l : near12[j]) {
          double r = r01;
          if (l == i || !fits(j, l, d12, &r) || !fits(i, l, d02, &r)) continue;
          Rigid3d pose;
          if (!AbsoluteOrientation({model[0], model[1], model[2]}, {x(i), x(j), x(l)}, &pose)) {
            continue;
          }
          Seed seed;
          seed.context = context;
          seed.assignment = {{0, index3_[i]}, {1, index3_[j]}, {2, index3_[l]}};
          seed.world_from_nominal = pose;
          seed.residual = r;
          Support(&seed, false);
          seeds->push_back(std::move(seed));
        }
      }
    }
  }

  // 2D: P3P on ordered triples of image points, checked by the fourth seed point.
  void ImageSeeds(const std::vector<ModelPointRef>& s, int context, std::vector<Seed>* seeds) {
    const Camera& camera = *set_.camera;
    const int comp = s[0].component;
    const Rigid3d world_from_comp = g_.nominal.poses[g_.blocks[g_.components[comp].block].index];
    std::array<Eigen::Vector3d, 3> object;
    for (int i = 0; i < 3; ++i) object[i] = g_.components[comp].points[s[i].feature].position;
    const Eigen::Vector3d fourth = g_.components[comp].points[s[3].feature].position;
    const int n = static_cast<int>(index2_.size());
    const double k2 = std::sqrt(gate2_);
    if (sigma2_image_.size() != n) {
      // Computed once: the check below runs for every P3P solution.
      sigma2_image_.resize(n);
      for (int m = 0; m < n; ++m) sigma2_image_[m] = LargestVariance(set_.points[index2_[m]].cov2);
    }
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int l = 0; l < n; ++l) {
          if (i == j || j == l || i == l) continue;
          if (p3p_calls_ >= kMaxP3pCalls) return;
          ++p3p_calls_;
          const std::array<Eigen::Vector2d, 3> image = {
              set_.points[index2_[i]].uv, set_.points[index2_[j]].uv, set_.points[index2_[l]].uv};
          for (const Rigid3d& camera_from_comp :
               options_.poses_from_three_projections(camera, object, image)) {
            const Eigen::Vector3d q = camera_from_comp * fourth;
            if (!(q.z() > 0)) continue;
            const Eigen::Vector2d uv = camera.Project<double>(q);
            int match = -1;
            double best = 0;
            for (int m = 0; m < n; ++m) {
              if (m == i || m == j || m == l) continue;
              const double d2 = (set_.points[index2_[m]].uv - uv).squaredNorm() / sigma2_image_[m];
              if (d2 > k2 * k2) continue;
              const double d = std::sqrt(d2);
              if (match < 0 || d < best) {
                match = m;
                best = d;
              }
            }
            if (match < 0) continue;
            Seed seed;
            seed.context = context;
            seed.assignment = {
                {0, index2_[i]}, {1, index2_[j]}, {2, index2_[l]}, {3, index2_[match]}};
            seed.world_from_nominal = camera_from_comp * world_from_comp.Inverse();
            seed.residual = best * best;
            Support(&seed, true);
            seeds->push_back(std::move(seed));
          }
        }
  }

  // The motions (in the nominal world) that joint `j`'s range gives its child with the parent
  // held, sampled finely enough that no point of either moves more than the support radius
  // between samples; empty where that takes too many samples or the joint has no variable.
  const std::vector<Rigid3d>& JointSweep(int j) const {
    if (auto it = sweeps_.find(j); it != sweeps_.end()) return it->second;
    std::vector<Rigid3d>& out = sweeps_[j];
    const Joint& joint = g_.joints[j];
    if (!HasJointVariable(joint.type) || !g_.components[joint.parent].rigid ||
        !g_.components[joint.child].rigid) {
      return out;
    }
    const double radius = 0.05 * extent_;
    const Rigid3d world_from_joint =
        g_.nominal.poses[g_.blocks[g_.components[joint.parent].block].index] *
        joint.parent_from_joint;
    double reach = 0;
    for (const int c : {joint.parent, joint.child}) {  // either side may be the one swept
      for (const FeaturePoint& p : g_.components[c].points) {
        const Eigen::Vector3d x = g_.nominal.poses[g_.blocks[g_.components[c].block].index] *
                                  p.position;
        reach = std::max(reach, (world_from_joint.Inverse() * x).norm());
      }
    }
    double lower = -M_PI, upper = M_PI;
    int samples = 1;
    if (joint.type == JointType::kPrismatic) {
      if (!joint.limits) return out;
      std::tie(lower, upper) = *joint.limits;
      samples = static_cast<int>(std::ceil((upper - lower) / radius)) + 1;
    } else {
      if (joint.limits && joint.type == JointType::kRevolute) {
        std::tie(lower, upper) = *joint.limits;
      }
      samples = static_cast<int>(std::ceil((upper - lower) * reach / radius)) + 1;
    }
    if (samples > kMaxSweepSamples) return out;  // too long a sweep for a cheap estimate
    const Rigid3d undo_nominal =
        JointMotion(joint.type, joint.axis, joint.nominal_position).Inverse();
    for (int i = 0; i < samples; ++i) {
      // Inside the range, never on a bound: a slack matched to a joint at its bound is zero,
      // where it has no derivative, and its constraint linearised there pins the joint at the
      // bound for the whole branch (the folding ruler swept to its end stops).
      const double q = lower + (upper - lower) * (i + 0.5) / samples;
      out.push_back(world_from_joint * JointMotion(joint.type, joint.axis, q) * undo_nominal *
                    world_from_joint.Inverse());
    }
    return out;
  }

  // Model points, placed at the seed's pose, that have a measurement within 5 % of the extent
  // (3D) or 3 % of the image diagonal (2D); and the most points that could match below the
  // seed. The seed's own component is placed rigidly; a component joined to a placed one by a
  // joint with a variable is placed where the joint, swept over its range, puts the most of
  // its points near a measurement (the nominal joint value says little: the joint moved), and
  // the search starts there; the rest keep the nominal geometry. The bound rules out the own
  // component's points away from every measurement, and a joined component's points that no
  // place along its joint's sweep brings near one; components farther along a chain may sit
  // anywhere their joints allow.
  void Support(Seed* seed_out, bool image) const {
    Seed& seed = *seed_out;
    std::vector<int> exclude;
    for (const auto& [level, m] : seed.assignment) exclude.push_back(m);
    std::vector<std::pair<Eigen::Vector3d, int>> points;
    if (!image) {
      if (!grid3_) {
        for (int i : index3_) points.push_back({set_.points[i].xyz, i});
        grid3_.emplace(0.05 * extent_, 3, points);
      }
    } else if (!grid2_) {
      const Camera& c = *set_.camera;
      diagonal_ = c.width > 0 ? std::hypot(c.width, c.height) : 1000.0;
      for (int i : index2_) {
        points.push_back({Eigen::Vector3d(set_.points[i].uv.x(), set_.points[i].uv.y(), 0), i});
      }
      grid2_.emplace(0.03 * diagonal_, 2, points);
    }
    const Context& ctx = contexts_[seed.context];
    const int own = ctx.points[0].component;
    auto near = [&](const Eigen::Vector3d& x) {
      if (!image) return grid3_->AnyWithin(x, 0.05 * extent_, exclude);
      if (!(x.z() > 0)) return false;
      const Eigen::Vector2d uv = set_.camera->Project<double>(x);
      return grid2_->AnyWithin(Eigen::Vector3d(uv.x(), uv.y(), 0), 0.03 * diagonal_, exclude);
    };
    const std::vector<std::vector<int>>& levels_of = LevelsOf(seed.context);
    if (joints_of_.empty()) {
      joints_of_.resize(g_.components.size());
      for (size_t j = 0; j < g_.joints.size(); ++j) {
        joints_of_[g_.joints[j].parent].push_back(static_cast<int>(j));
        joints_of_[g_.joints[j].child].push_back(static_cast<int>(j));
      }
    }
    // From the own component placed at `start`: each component joined to it, and on along the
    // chain, where its joint's sweep brings the most points near a measurement; the points so
    // brought near (support, the own component's included); and per level of the own
    // component and of each component joined to it, whether it is near a measurement
    // somewhere along the sweep (empty: not swept). Only these can match, wherever the joint
    // is. Components farther along a chain can sit in more places than one sweep shows.
    struct Placing {
      Rigid3d start;
      std::vector<Rigid3d> placement;
      std::vector<bool> placed;
      std::vector<std::vector<bool>> reached;  // per component, per level of levels_of
      int support = 0;
    };
    auto place = [&](const Rigid3d& start) {
      Placing out;
      out.start = start;
      out.placement.assign(g_.components.size(), start);
      out.placed.assign(g_.components.size(), false);
      out.reached.resize(g_.components.size());
      out.placed[own] = true;
      std::vector<bool>& own_reached = out.reached[own];
      for (int level : levels_of[own]) {
        own_reached.push_back(near(start * ctx.nominal[level]));
        out.support += own_reached.back() ? 1 : 0;
      }
      std::vector<int> queue = {own};
      for (size_t head = 0; head < queue.size(); ++head) {
        const int c = queue[head];
        for (const int j : joints_of_[c]) {
          const Joint& joint = g_.joints[j];
          const int other = joint.parent == c ? joint.child : joint.parent;
          if (out.placed[other]) continue;
          const std::vector<Rigid3d>& sweep = JointSweep(j);
          // In an image a long sweep finds some clutter near most of its places, and a
          // placement chosen that way is worse than the nominal one (the four-bar from one
          // camera: right in 14 % of trials with whole turns swept, 36 % without).
          if (sweep.empty() || (image && sweep.size() > kMaxImageSweepSamples)) continue;
          const std::vector<int>& levels = levels_of[other];
          std::vector<bool> reached(levels.size(), false);
          int most = 0;
          Rigid3d best = out.placement[c];
          for (const Rigid3d& delta : sweep) {
            const Rigid3d moved =
                out.placement[c] * (joint.parent == c ? delta : delta.Inverse());
            int count = 0;
            for (size_t i = 0; i < levels.size(); ++i) {
              if (near(moved * ctx.nominal[levels[i]])) {
                ++count;
                reached[i] = true;
              }
            }
            if (count > most) {
              most = count;
              best = moved;
            }
          }
          if (c == own) out.reached[other] = std::move(reached);
          out.placement[other] = best;
          out.placed[other] = true;
          out.support += most;
          queue.push_back(other);
        }
      }
      return out;
    };
    std::vector<Placing> placings = {place(seed.world_from_nominal)};
    // A seed's own noise leaves it turned about its weakest axis by σ / sqrt(λ), λ the
    // smallest eigenvalue of Σ |q|² I - q qᵀ over its centred points q (3D). A thin seed (a
    // blade's pivot, tip and ring, 12 mm off one line) turns by 0.2 rad for 2 mm of noise, and
    // a joint swept from it passes its neighbour's points by centimetres: the tree then starts
    // the neighbour far from its points, its linearised gates miss them, and the bound rules
    // out the seed that holds the answer. So the seed is also placed turned within 3 sigmas,
    // in steps that move the model's farthest point by the sweep's radius: the placing that
    // brings the most points near starts the search, and the bound counts every point that
    // one of them brings near.
    if (!image && !joints_of_[own].empty()) {
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      double noise = 0;
      for (const auto& [level, m] : seed.assignment) {
        centre += ctx.nominal[level];
        noise = std::max(noise, LargestVariance(set_.points[m].cov3));
      }
      centre /= static_cast<double>(seed.assignment.size());
      Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
      for (const auto& [level, m] : seed.assignment) {
        const Eigen::Vector3d q = ctx.nominal[level] - centre;
        spread += q.squaredNorm() * Eigen::Matrix3d::Identity() - q * q.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(spread);
      const double turn_sigma =
          eigen.eigenvalues()[0] > 0 ? std::sqrt(noise / eigen.eigenvalues()[0]) : 1.0;
      double reach = 0;
      for (int l = 0; l < levels_; ++l) reach = std::max(reach, (ctx.nominal[l] - centre).norm());
      const double step = 0.05 * extent_ / std::max(reach, 1e-9);
      const double span = 3 * std::min(turn_sigma, 1.0);  // radians either way
      const int turns = std::min(8, static_cast<int>(std::ceil(span / step)));
      const Eigen::Vector3d axis = seed.world_from_nominal.rotation * eigen.eigenvectors().col(0);
      const Eigen::Vector3d pivot = seed.world_from_nominal * centre;
      for (int k = -turns; turns > 1 && k <= turns; ++k) {
        if (k == 0) continue;
        const Eigen::Matrix3d turn =
            Eigen::AngleAxisd(span * k / turns, axis).toRotationMatrix();
        placings.push_back(
            place(Rigid3d(turn, pivot - turn * pivot) * seed.world_from_nominal));
      }
    }
    int bound = 0;
    for (size_t c = 0; c < g_.components.size(); ++c) {
      if (placings[0].reached[c].empty() && static_cast<int>(c) != own) {
        bound += static_cast<int>(levels_of[c].size());  // not swept: anywhere
        continue;
      }
      for (size_t i = 0; i < placings[0].reached[c].size(); ++i) {
        bound += std::any_of(placings.begin(), placings.end(),
                             [&](const Placing& p) { return p.reached[c][i]; })
                     ? 1
                     : 0;
      }
    }
    const Placing& placing = *std::max_element(
        placings.begin(), placings.end(),
        [](const Placing& a, const Placing& b) { return a.support < b.support; });
    seed.world_from_nominal = placing.start;
    seed.placement = placing.placement;
    // Single points and components no joint reaches: at the seed's motion of the nominal
    // geometry.
    int support = placing.support;
    for (int l = 0; l < levels_; ++l) {
      const int c = ctx.points[l].component;
      if (placing.placed[c]) continue;
      support += near(seed.world_from_nominal * ctx.nominal[l]) ? 1 : 0;
    }
    seed.support = support;
    seed.bound = bound;
  }

  // Per component, the plan levels of its points in plan `context`.
  const std::vector<std::vector<int>>& LevelsOf(int context) const {
    if (auto it = levels_of_.find(context); it != levels_of_.end()) return it->second;
    std::vector<std::vector<int>>& out = levels_of_[context];
    out.resize(g_.components.size());
    for (int l = 0; l < levels_; ++l) out[contexts_[context].points[l].component].push_back(l);
    return out;
  }

  // ---- The tree --------------------------------------------------------------------------
  //
  // A frame at level k holds the state after the matches above it and the level's constraints
  // that do not touch the level's component (`pre`). The level's other constraints (`own`,
  // which place the point relative to matched ones) are fused after the candidate's
  // measurement: fused before it, they would be linearised where the point is guessed to be,
  // and a hard constraint linearised there confines the prediction to a tangent plane the true
  // point may be centimetres off (the first point of a joint that moved). After the
  // measurement, each own constraint is linearised at the measured point, and its innovation
  // NIS tests the match exactly.

  void Search(const Seed* seed) {
    context_ = seed ? seed->context : 0;
    ctx_ = &contexts_[context_];
    Values initial = g_.nominal;
    if (seed) {
      for (Eigen::Vector3d& p : initial.points) p = seed->world_from_nominal * p;
      for (size_t c = 0; c < g_.components.size(); ++c) {
        const Block& b = g_.blocks[g_.components[c].block];
        if (b.kind == BlockKind::kPose) {
          const Rigid3d& motion =
              seed->placement.empty() ? seed->world_from_nominal : seed->placement[c];
          initial.poses[b.index] = motion * g_.nominal.poses[b.index];
        }
      }
      // A component the sweep placed has moved its joint: an inequality's slack kept at its
      // nominal value contradicts the placement (the scissors' opening placed at its limit,
      // the slack still saying 25 degrees), and its first fusion pulls the component back.
      MatchSlacks(g_, &initial);
    }
    PriorScale scale;
    scale.position = options_.solve.prior_extent_factor * extent_;
    scale.rotation = options_.solve.prior_rotation_sigma;
    scale.slack = options_.solve.prior_slack_sigma;
    Frame root;
    root.state = MakePrior(g_.blocks, initial, scale);
    root.null_component.assign(g_.components.size(), false);
    root.tried.assign(g_.components.size(), 0);
    root.done.assign(levels_, 0);
    root.revisit.assign(levels_, 0);
    for (int l = 1; l < levels_; ++l) root.pending.push_back(l);
    preassigned_.assign(levels_, -1);
    assignment_.assign(levels_, -1);
    if (seed) {
      // The seed's matches, fused first; their levels take no other branch.
      for (const auto& [level, m] : seed->assignment) {
        preassigned_[level] = m;
        ++stats_.nodes;
        const Factor f = MeasurementFactor(g_, set_, ctx_->points[level], m, !set_.points[m].is_3d);
        if (!Fuse(f, &root.state).changed_state()) {
          ++stats_.backtracks;
          return;
        }
      }
    }
    if (!EnterLevel(&root)) {
      ++stats_.backtracks;
      return;
    }
    // Iterative deepening on null branches without repeating a round's work: round k resumes
    // only the null branches round k-1 could not take (each saved with its frame), since every
    // other branch below them was searched then. When too many are waiting to be kept, the next
    // round searches again from the root.
    std::vector<Resume> roots(1);
    roots[0].frame = root;
    roots[0].assignment = assignment_;
    for (int nulls = 0; nulls <= levels_ && !found_ && !roots.empty(); ++nulls) {
      if (best_matched_ >= 0 && levels_ - nulls <= best_matched_) break;
      max_nulls_ = nulls;
      waiting_.clear();
      overflow_ = false;
      for (Resume& r : roots) {
        SearchBelow(std::move(r));
        if (found_ || stats_.status == SearchStats::Status::kBudget) return;
      }
      if (overflow_) {
        roots.assign(1, Resume{root, {}, std::vector<int>(levels_, -1)});
      } else {
        roots = std::move(waiting_);
      }
      waiting_.clear();
    }
  }

  // A frame whose remaining candidates are to be searched, with the branch above it.
  struct Resume {
    Frame frame;
    std::vector<std::pair<int, std::vector<std::pair<int, double>>>> trace;  // (level, best3)
    std::vector<int> assignment;
  };
  static constexpr size_t kMaxWaiting = 1024;

  // Depth first below r's frame, within the round's null branches.
  void SearchBelow(Resume r) {
    assignment_ = r.assignment;
    trace_prefix_ = std::move(r.trace);
    std::vector<Frame> stack;
    stack.push_back(std::move(r.frame));
    while (!stack.empty()) {
      Frame& f = stack.back();
      if (f.next == f.candidates.size()) {
        stack.pop_back();
        continue;
      }
      const Candidate c = f.candidates[f.next++];
      const int real = c.measurement >= 0 ? 1 : 0;
      // A blind point's first null only postpones it: not counted.
      const bool postpone = f.blind && !f.revisit[f.level];
      // Single points only: a rigid component's features stand or fall with its pose, and a
      // free null would hide the one feature that shows a pose wrong (the box's lid faces).
      const bool free_null = !real && f.evidenced_null &&
                             f.free_nulls < options_.free_evidenced_nulls &&
                             !g_.components[ctx_->points[f.level].component].rigid;
      // The null branch after a confident match passed its tests is not tried: the point is
      // there (Lowe's probability that the measurement is clutter is below 1 %). Its other
      // candidates still are: pruned too, the hinged box lost 1.5-2 % of its trials.
      if (!real && !postpone && options_.probability_order && f.confident_passed) continue;
      if (!real && !postpone && !free_null && f.nulls >= max_nulls_) {
        // For the next round, unless too many wait already.
        if (waiting_.size() >= kMaxWaiting) {
          overflow_ = true;
        } else if (!overflow_) {
          Resume w{f, trace_prefix_, assignment_};
          w.frame.candidates = {c};
          w.frame.next = 0;
          for (const Frame& above : stack) {
            if (&above != &f) w.trace.push_back({above.level, above.best3});
          }
          waiting_.push_back(std::move(w));
        }
        continue;
      }
      // Can this branch still match more points than the best so far?
      const int can_match = f.matched + real + static_cast<int>(f.pending.size());
      if (best_matched_ >= 0 && can_match <= best_matched_) continue;
      if (stats_.nodes >= options_.max_nodes) {
        stats_.status = SearchStats::Status::kBudget;
        return;
      }
      ++stats_.nodes;
      Frame child;
      child.done = f.done;
      child.revisit = f.revisit;
      child.pending = f.pending;
      if (postpone) {
        child.pending.push_back(f.level);  // postponed to the end of the branch
        child.revisit[f.level] = 1;
      } else {
        child.done[f.level] = 1;
      }
      const bool leaf = child.pending.empty();
      if (!leaf) {
        child.level = child.pending.front();
        child.pending.erase(child.pending.begin());
      }
      child.state = f.state;
      child.matched = f.matched + real;
      child.nulls = f.nulls + (real || postpone || free_null ? 0 : 1);
      child.free_nulls = f.free_nulls + (free_null ? 1 : 0);
      child.nis_sum = f.nis_sum;
      child.nis_dof = f.nis_dof;
      child.null_component = f.null_component;
      child.tried = f.tried;
      child.deferred = f.deferred;
      assignment_[f.level] = c.measurement;
      const int component = ctx_->points[f.level].component;
      if (!real && !g_.components[component].rigid) child.null_component[component] = true;
      if (real && f.revisit[f.level]) {
        // A postponed point matched: its constraints waiting on it are its own now.
        child.null_component[component] = false;
        for (int k : f.own)
          child.deferred.erase(std::find(child.deferred.begin(), child.deferred.end(), k));
      }
      double delta = 0;  // the match's: its own NIS and that of the constraints placing it
      if (real && preassigned_[f.level] < 0) {
        const bool image = !set_.points[c.measurement].is_3d;
        const Factor factor =
            MeasurementFactor(g_, set_, ctx_->points[f.level], c.measurement, image);
        const FusionSummary s = Fuse(factor, &child.state);
        if (!s.changed_state()) {
          ++stats_.backtracks;
          continue;
        }
        delta += s.final_nis;
        child.nis_sum += s.final_nis;
        child.nis_dof += image ? 2 : 3;
      }
      double own_nis = 0;
      if (!FuseConstraints(f.own, &child, &own_nis) || !FuseDeferred(&child)) {
        ++stats_.backtracks;
        continue;
      }
      // A match is scored by its own innovation and by how far the constraints placing it had
      // to move (both vanish for a perfect match); the null branch scores 0.
      if (real) delta += own_nis;
      child.delta_sum = f.delta_sum + delta;
      if (!JointlyCompatible(child) || (real && delta > f.gate)) {
        ++stats_.backtracks;
        continue;
      }
      ++stats_.expanded;
      if (real && c.probability >= kConfident) f.confident_passed = true;
      if (leaf) {
        double trailing_nis = 0;
        if (FuseConstraints(ctx_->plan.trailing, &child, &trailing_nis) && FuseRemaining(&child) &&
            JointlyCompatible(child)) {
          Leaf(child, stack);
          return;  // the first complete interpretation of the round
        } else {
          ++stats_.backtracks;
        }
        continue;
      }
      if (!EnterLevel(&child)) {
        ++stats_.backtracks;
        continue;
      }
      if (best_matched_ < 0 && child.matched > partial_.matched) {
        // The best branch so far, for when the budget ends the search before any leaf.
        partial_.matched = child.matched;
        partial_.context = context_;
        partial_.support = seed_support_;
        partial_.assignment.assign(levels_, -1);
        for (int l = 0; l < levels_; ++l) {
          partial_.assignment[l] = preassigned_[l] >= 0 ? preassigned_[l]
                                   : child.done[l]      ? assignment_[l]
                                                        : -1;
        }
        partial_.mean = child.state.mean;
      }
      stack.push_back(std::move(child));
    }
  }

  // The chi-square quantile at the gate confidence for `dof` degrees of freedom, computed once
  // per dof and confidence in a thread: the tests below ask for it at every node, and a
  // tracker interprets frame after frame at one confidence.
  double Gate(int dof) const {
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

  bool JointlyCompatible(const Frame& f) const {
    if (!options_.joint_compatibility || f.nis_dof == 0) return true;
    return f.nis_sum <= Gate(f.nis_dof);
  }

  // Fuses `list` into f's state; false when a constraint contradicts what was fused before it,
  // fails, or its innovation NIS is outside the chi-square gate for its rows. Adds the NIS to
  // *nis.
  bool FuseConstraints(const std::vector<int>& list, Frame* f, double* nis) const {
    for (int k : list) {
      if (!use_[k]) continue;
      const std::vector<int>& comps = constraint_components_[k];
      if (std::any_of(comps.begin(), comps.end(), [&](int c) { return f->null_component[c]; })) {
        f->deferred.push_back(k);
        continue;
      }
      const Constraint& c = g_.constraints[k];
      if (!Accept(Fuse({c.residual, c.blocks, {}, c.name}, &f->state), f, nis)) return false;
    }
    return true;
  }

  // Whether a constraint's fusion is consistent: not refused, converged, and its innovation
  // NIS inside the chi-square gate for its rows (then added to the branch's and to *nis).
  bool Accept(const FusionSummary& s, Frame* f, double* nis) const {
    if (s.status == FusionSummary::Status::kContradiction ||
        s.status == FusionSummary::Status::kInvalid ||
        s.status == FusionSummary::Status::kNotConverged) {
      return false;
    }
    if (s.rows_fused > 0) {
      if (s.final_nis > Gate(s.rows_fused)) return false;
      f->nis_sum += s.final_nis;
      f->nis_dof += s.rows_fused;
      *nis += s.final_nis;
    }
    return true;
  }

  // Fuses the deferred constraints of each occluded point that can now be placed: re-centred
  // on its matched neighbours (Recentre), every deferred constraint on it whose other
  // components are matched. False when one of them is inconsistent.
  bool FuseDeferred(Frame* f) const {
    if (f->deferred.empty()) return true;
    for (size_t n = 0; n < g_.components.size(); ++n) {
      if (!f->null_component[n]) continue;
      std::vector<int> ready;
      for (int k : f->deferred) {
        const std::vector<int>& comps = constraint_components_[k];
        if (std::find(comps.begin(), comps.end(), static_cast<int>(n)) == comps.end()) continue;
        // Its other points matched, or occluded and placed already.
        const bool others_known = std::all_of(comps.begin(), comps.end(), [&](int c) {
          return c == static_cast<int>(n) || !f->null_component[c];
        });
        if (others_known) ready.push_back(k);
      }
      // Tried once per set of ready constraints: the attempt below fails the same way until
      // another neighbour is matched.
      if (static_cast<int>(ready.size()) <= f->tried[n]) continue;
      f->tried[n] = static_cast<int>(ready.size());
      Eigen::Vector3d& point = f->state.mean.points[g_.blocks[g_.components[n].block].index];
      const Eigen::Vector3d guessed = point;
      if (!Recentre(f, static_cast<int>(n)) || !Determine(ready, static_cast<int>(n), *f) ||
          !Place(ready, static_cast<int>(n), f)) {
        point = guessed;
        continue;
      }
      GaussianState saved = f->state;
      // Together: fused one by one, a constraint linearised at the re-centred guess can leave
      // the next one degenerate (combined_constraint.h).
      std::vector<Factor> parts;
      for (int k : ready) {
        const Constraint& c = g_.constraints[k];
        parts.push_back({c.residual, c.blocks, {}, c.name});
      }
      const Factor joint = parts.size() == 1
                               ? parts[0]
                               : CombinedConstraint(parts, block_kinds_, ModelPointName(g_, n, -1));
      const FusionSummary s = Fuse(joint, &f->state, joint_fusion_);
      if (s.status == FusionSummary::Status::kNotConverged) {
        // The neighbours matched so far place the point only ill-conditioned (it sits where
        // their spheres touch): it waits for more of them.
        f->state = std::move(saved);
        f->state.mean.points[g_.blocks[g_.components[n].block].index] = guessed;
        continue;
      }
      double nis = 0;
      if (!Accept(s, f, &nis)) return false;
      f->null_component[n] = false;  // placed: its constraints are fused from now on
      for (int k : ready) f->deferred.erase(std::find(f->deferred.begin(), f->deferred.end(), k));
    }
    return true;
  }

  // At a leaf: the constraints still waiting on occluded points, fused together as one factor
  // (each such point first re-centred on its neighbours) and tested, so that every constraint
  // has checked the matches before the leaf counts. False when they disagree with them.
  bool FuseRemaining(Frame* f) const {
    if (f->deferred.empty()) return true;
    for (size_t n = 0; n < g_.components.size(); ++n) {
      if (!f->null_component[n] || !Recentre(f, static_cast<int>(n))) continue;
      std::vector<int> own;
      for (int k : f->deferred) {
        const std::vector<int>& comps = constraint_components_[k];
        if (std::find(comps.begin(), comps.end(), static_cast<int>(n)) != comps.end()) {
          own.push_back(k);
        }
      }
      Place(own, static_cast<int>(n), f);
    }
    std::vector<Factor> parts;
    for (int k : f->deferred) {
      const Constraint& c = g_.constraints[k];
      parts.push_back({c.residual, c.blocks, {}, c.name});
    }
    f->deferred.clear();
    double nis = 0;
    GaussianState saved = f->state;
    const FusionSummary s =
        Fuse(CombinedConstraint(parts, block_kinds_, "deferred"), &f->state, joint_fusion_);
    if (s.status == FusionSummary::Status::kNotConverged) {
      // The points stay determined only at second order (see Determine): their iterations do
      // not settle, but the first, linearised where the points were guessed, still tests the
      // matches.
      f->state = std::move(saved);
      return s.rows_fused == 0 || s.innovation_nis <= Gate(s.rows_fused);
    }
    return Accept(s, f, &nis);
  }

  // Moves single point `component` (re-centred near its place) to where constraints `list`
  // hold best with everything else fixed: Levenberg-Marquardt on the sum of their squared
  // residuals. The re-centring maps the nominal geometry rigidly onto matched neighbours that
  // may belong to parts turned about a joint between them, which can leave the point
  // centimetres off; linearised there, its constraints would disagree with matches that are
  // right. False when the residuals are not finite.
  bool Place(const std::vector<int>& list, int component, Frame* f) const {
    return PlacePoint(g_, list, g_.components[component].block, &f->state.mean,
                      {.max_iterations = kPlaceIterations});
  }

  // Whether constraints `list` determine single point `component` where it is now guessed:
  // their rows, each scaled to a unit gradient in the point, span all three directions well
  // (smallest singular value above 0.1). Two distances leave it a circle; three whose centres
  // are coplanar with it meet there only tangentially. Either way its place would be the
  // guess's, and the constraints fused there would pin it wrongly.
  bool Determine(const std::vector<int>& list, int component, const Frame& f) const {
    const int point_block = g_.components[component].block;
    std::vector<Eigen::RowVector3d> rows;
    Eigen::VectorXd r;
    Eigen::MatrixXd H;
    for (int k : list) {
      const Constraint& c = g_.constraints[k];
      EvaluateResidual(*c.residual, g_.blocks, c.blocks, f.state.mean, &r, &H);
      int column = 0;
      for (int b : c.blocks) {
        if (b == point_block) {
          for (int i = 0; i < H.rows(); ++i) {
            const Eigen::RowVector3d row = H.block<1, 3>(i, column);
            if (row.norm() > 0) rows.push_back(row.normalized());
          }
        }
        column += TangentDim(g_.blocks[b].kind);
      }
    }
    if (rows.size() < 3) return false;
    // The smallest singular value of the stacked rows is the root of the smallest eigenvalue
    // of their 3 x 3 Gram matrix (0.1 is far above where forming it loses precision).
    Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
    for (const Eigen::RowVector3d& row : rows) gram.noalias() += row.transpose() * row;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(gram, Eigen::EigenvaluesOnly);
    return eigen.eigenvalues()(0) > kDetermined * kDetermined;
  }

  // Whether component c has a match on f's branch (a seed's or a level's).
  bool IsMatched(const Frame& f, int c) const {
    for (int l = 0; l < levels_; ++l) {
      if (ctx_->points[l].component != c) continue;
      if (preassigned_[l] >= 0 || (f.done[l] && assignment_[l] >= 0)) return true;
    }
    return false;
  }

  // Sets up f for its level: fuses the level's constraints that do not touch its component,
  // keeps the others for after the match, and lists the candidates.
  bool EnterLevel(Frame* f) const {
    const int level = f->level;
    const int component = ctx_->points[level].component;
    f->own.clear();
    std::vector<int> pre;
    if (!f->revisit[level]) {
      for (int k : ctx_->plan.levels[level].constraints) {
        if (!use_[k]) continue;
        const std::vector<int>& comps = constraint_components_[k];
        (std::find(comps.begin(), comps.end(), component) != comps.end() ? f->own : pre)
            .push_back(k);
      }
      f->gate = ctx_->level_gate[level];
    } else {
      // A postponed point: its own constraints are those still waiting on it alone.
      int rows = image_ ? 2 : 3;
      for (int k : f->deferred) {
        const std::vector<int>& comps = constraint_components_[k];
        if (std::find(comps.begin(), comps.end(), component) == comps.end()) continue;
        if (std::any_of(comps.begin(), comps.end(),
                        [&](int c) { return c != component && f->null_component[c]; })) {
          continue;
        }
        f->own.push_back(k);
        rows += g_.constraints[k].residual->dimension();
      }
      f->gate = Gate(rows);
    }
    double nis = 0;
    if (!FuseConstraints(pre, f, &nis)) return false;
    Recentre(f, component);
    BuildCandidates(f);
    return true;
  }

  // Where the filter linearises an unmatched component decides what its constraints predict.
  // The seed placed the whole nominal model rigidly, which is far off for parts beyond a few
  // joints; so while the component is still untouched by any fusion (its mean is free under
  // the vague prior), it is placed with the nominal geometry relative to its matched
  // neighbours: the rigid motion of a matched rigid neighbour, or the one that best maps three
  // or more matched neighbouring points onto their estimates.
  bool Recentre(Frame* f, int component) const {
    GaussianState& state = f->state;
    const int block = g_.components[component].block;
    std::vector<int> group;
    if (state.groups.num_blocks() == static_cast<int>(g_.blocks.size())) {
      state.groups.Support(std::vector<int>{block}, &group);
      if (group.size() > 1) return false;
    }
    std::vector<bool> matched(g_.components.size(), false);
    for (size_t c = 0; c < g_.components.size(); ++c) {
      matched[c] = IsMatched(*f, static_cast<int>(c));
    }
    std::vector<Eigen::Vector3d> from, to;
    std::optional<Rigid3d> motion;
    for (size_t k = 0; k < g_.constraints.size() && !motion; ++k) {
      const std::vector<int>& comps = constraint_components_[k];
      if (!use_[k] || std::find(comps.begin(), comps.end(), component) == comps.end()) continue;
      for (int n : comps) {
        if (n == component || !matched[n]) continue;
        const Component& c = g_.components[n];
        const Block& b = g_.blocks[c.block];
        if (c.rigid) {
          motion = state.mean.poses[b.index] * g_.nominal.poses[b.index].Inverse();
          break;
        }
        if (std::find(to.begin(), to.end(), state.mean.points[b.index]) == to.end()) {
          from.push_back(g_.nominal.points[b.index]);
          to.push_back(state.mean.points[b.index]);
        }
      }
    }
    if (!motion) {
      Rigid3d fit;
      if (!AbsoluteOrientation(from, to, &fit)) return false;
      motion = fit;
    }
    const Block& b = g_.blocks[block];
    if (g_.components[component].rigid) {
      state.mean.poses[b.index] = *motion * g_.nominal.poses[b.index];
    } else {
      state.mean.points[b.index] = *motion * g_.nominal.points[b.index];
    }
    return true;
  }

  // The level's candidates, best first, and the null branch:
  //  (A) unused measurements inside the gate around the point predicted with every constraint
  //      of the level fused (linearised where the point is now guessed);
  //  (B) for a single point, the other unused measurements at which each own constraint,
  //      evaluated exactly with the point moved there, is within its gate: they lie on the
  //      constraints' curved locus (a sphere, a circle) beyond the linear prediction.
  void BuildCandidates(Frame* f) const {
    const int level = f->level;
    f->candidates.clear();
    f->best3.clear();
    f->blind = false;
    if (preassigned_[level] >= 0) {
      f->candidates = {{preassigned_[level], 0, 1, true}};
      f->best3 = {{preassigned_[level], 0}};
      return;
    }
    if (options_.postpone_blind &&
        (f->revisit[level] ? f->null_component[ctx_->points[level].component] && f->own.empty()
                           : Blind(*f))) {
      // Every measurement would pass its gate and no constraint could test it: a branch per
      // measurement, each searched below, for a point that predicts nothing. It is taken as
      // unmatched here, placed once its neighbours are (FuseDeferred), and re-associated under
      // the interpretation's estimate (Refine).
      f->blind = true;
      f->candidates = {Candidate{-1, 0, 0, true}};
      return;
    }
    std::vector<bool> used = duplicate_;
    for (int l = 0; l < levels_; ++l) {
      if (preassigned_[l] >= 0) used[preassigned_[l]] = true;
      if (f->done[l] && assignment_[l] >= 0) used[assignment_[l]] = true;
    }
    // (A): the linear prediction.
    const auto [p3, p2] = PredictWithOwn(*f, ctx_->points[level]);
    std::vector<bool> listed(set_.points.size(), false);
    for (size_t m = 0; m < set_.points.size(); ++m) {
      if (used[m]) continue;
      const MeasuredPoint& z = set_.points[m];
      const std::optional<Candidate> scored = Score(z.is_3d ? p3 : p2, static_cast<int>(m));
      if (!scored) continue;
      f->candidates.push_back(*scored);
      listed[m] = true;
    }
    std::vector<Candidate>& c = f->candidates;
    std::sort(c.begin(), c.end(), [](const Candidate& a, const Candidate& b) {
      return a.delta < b.delta || (a.delta == b.delta && a.measurement < b.measurement);
    });
    if (options_.probability_order) {
      std::stable_sort(c.begin(), c.end(), [](const Candidate& a, const Candidate& b) {
        return a.probability > b.probability;
      });
    }
    // (B): the exact locus of a single point's own constraints; not needed where a candidate
    // is confident (p/(p+q) >= kConfident under a prediction that says something): the
    // linearisation the locus corrects is then good.
    const bool confident = options_.probability_order && !c.empty() && c[0].informative &&
                           c[0].probability >= kConfident;
    std::vector<Candidate> locus;
    if (!confident) locus = LocusCandidates(*f, used, listed);
    // The null branch: last (the paper), or before the first candidate more likely clutter
    // (where the prediction is sharp enough to say so).
    size_t at = c.size();
    if (options_.probability_order) {
      for (size_t i = 0; i < c.size(); ++i) {
        if (c[i].informative && c[i].probability < 0.5) {
          at = i;
          break;
        }
      }
    }
    f->evidenced_null = false;
    if (c.empty() && locus.empty() && options_.free_evidenced_nulls > 0) {
      // Whether the gate would hold less than one clutter point on average (Score's flag, for
      // any measurement of the data's kind: they share one noise level in practice).
      for (size_t m = 0; m < set_.points.size(); ++m) {
        if (duplicate_[m]) continue;
        const std::optional<Candidate> s =
            Score(set_.points[m].is_3d ? p3 : p2, static_cast<int>(m), false);
        f->evidenced_null = s && s->informative;
        break;
      }
    }
    c.insert(c.begin() + static_cast<long>(at), Candidate{-1, 0, 0, true});
    c.insert(c.end() - (at == c.size() - 1 ? 1 : 0), locus.begin(), locus.end());
    std::vector<Candidate> all = c;
    std::sort(all.begin(), all.end(),
              [](const Candidate& a, const Candidate& b) { return a.delta < b.delta; });
    for (const Candidate& x : all) {
      if (x.measurement >= 0 && f->best3.size() < 3) f->best3.push_back({x.measurement, x.delta});
    }
  }

  // Whether f's level is a single point whose every own constraint (those linking it to the
  // points matched before it) waits on an occluded point: its prediction is the vague prior.
  bool Blind(const Frame& f) const {
    const int component = ctx_->points[f.level].component;
    if (g_.components[component].rigid || f.own.empty()) return false;
    return std::all_of(f.own.begin(), f.own.end(), [&](int k) {
      const std::vector<int>& comps = constraint_components_[k];
      return std::any_of(comps.begin(), comps.end(),
                         [&](int c) { return c != component && f.null_component[c]; });
    });
  }

  // δ = (p - z)ᵀ (P + Λ)⁻¹ (p - z) and log det(P + Λ) for an N-vector measurement, in fixed
  // sizes: this runs for every measurement at every level. False when the prediction has
  // another size or P + Λ is not positive definite.
  template <int N>
  static bool Mahalanobis(const Prediction& p, const Eigen::Matrix<double, N, 1>& z,
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

  // Measurement m against a prediction of its model point: its δ, Lowe's probability and
  // whether the gate is informative; nothing when outside the gate (unless not `gated`).
  std::optional<Candidate> Score(const Prediction& p, int m, bool gated = true) const {
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

  // ---- Refinement -------------------------------------------------------------------------
  //
  // The tree decides each match from the estimate of the points matched before it; the
  // interpretation's own estimate, from all its matches and every constraint, predicts every
  // model point far better (an occluded point's neighbours on both sides, not only those
  // before it). Measurements are re-associated to those predictions: each (point, measurement)
  // pair inside the gate and likelier the point than clutter (p > q) is a candidate, and pairs
  // are taken by decreasing log(p/q), each point and measurement once. The new labelling
  // replaces the old one when its total log(p/q) under the same estimate is larger.

  // Per level of `context`: the re-associated measurement, or -1.
  std::vector<int> Reassociate(int context, const GaussianState& state) const {
    struct Pair {
      double score;
      int level, measurement;
    };
    std::vector<Pair> pairs;
    const Context& ctx = contexts_[context];
    for (int l = 0; l < levels_; ++l) {
      const auto [p3, p2] = PredictPoint(ctx.points[l], state);
      for (size_t m = 0; m < set_.points.size(); ++m) {
        if (duplicate_[m]) continue;
        const std::optional<Candidate> c =
            Score(set_.points[m].is_3d ? p3 : p2, static_cast<int>(m));
        if (c && c->log_ratio > 0) pairs.push_back({c->log_ratio, l, static_cast<int>(m)});
      }
    }
    std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
      return a.score > b.score || (a.score == b.score && std::tie(a.level, a.measurement) <
                                                             std::tie(b.level, b.measurement));
    });
    std::vector<int> assignment(levels_, -1);
    std::vector<bool> taken(set_.points.size(), false);
    for (const Pair& p : pairs) {
      if (assignment[p.level] >= 0 || taken[p.measurement]) continue;
      assignment[p.level] = p.measurement;
      taken[p.measurement] = true;
    }
    return assignment;
  }

  // The total log(p/q) of a labelling under `state` (no gate: a match far off scores low).
  double LabellingScore(int context, const std::vector<int>& assignment,
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

  // The point's prediction once the level's own constraints are fused, computed on the
  // marginal of the blocks they and the point touch rather than on a copy of the whole state:
  // conditioning on constraints over a set of blocks changes that set's marginal through that
  // marginal alone, so the prediction is the same (the lamp's 69 coordinates against 12 or so:
  // a tenth of the interpretation's time).
  std::pair<Prediction, Prediction> PredictWithOwn(const Frame& f, ModelPointRef point) const {
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

  std::pair<Prediction, Prediction> PredictPoint(ModelPointRef point,
                                                 const GaussianState& state) const {
    Prediction p3, p2;
    if (!index3_.empty()) p3 = Predict(MeasurementFactor(g_, set_, point, -1, false), state);
    if (!index2_.empty()) p2 = Predict(MeasurementFactor(g_, set_, point, -1, true), state);
    return {p3, p2};
  }

  std::vector<Candidate> LocusCandidates(const Frame& f, const std::vector<bool>& used,
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

  void Leaf(const Frame& f, const std::vector<Frame>& path) {
    found_ = true;
    best_seed_support_ = seed_support_;
    best_matched_ = f.matched;
    best_delta_ = f.delta_sum;
    best_context_ = context_;
    best_assignment_ = assignment_;
    best_mean_ = f.state.mean;
    for (int l = 0; l < levels_; ++l) {
      if (preassigned_[l] >= 0) best_assignment_[l] = preassigned_[l];
    }
    best_trace_.assign(levels_, {});
    for (const auto& [level, best3] : trace_prefix_) best_trace_[level] = best3;
    for (const Frame& frame : path) best_trace_[frame.level] = frame.best3;
    best_predicted_ = 0;
    for (const Frame& frame : path) {
      const int m = assignment_[frame.level];
      if (m < 0) continue;
      for (const Candidate& c : frame.candidates) {
        if (c.measurement == m && c.informative) ++best_predicted_;
      }
    }
  }

  const ConstraintGraph& g_;
  const MeasurementSet& set_;
  const InterpretOptions& options_;
  const std::vector<bool> use_;  // per constraint: fused in the tree
  std::vector<std::vector<int>> constraint_components_;
  std::vector<Context> contexts_;  // [0]: the model's own plan; then one per seed set
  int context_ = 0;
  const Context* ctx_ = nullptr;  // of the search under way
  int best_context_ = 0;
  int levels_ = 0;
  bool image_ = false;                // image measurements only
  std::vector<int> index3_, index2_;  // 3D and 2D measurements, first copies only
  std::vector<bool> duplicate_;       // per measurement: a repeat of an earlier one
  std::vector<Seed> seeds_;
  std::vector<bool> searched_;
  std::vector<int> searched_beyond_;  // per seed searched: the best match count it had to beat
  int seed_support_ = 0;       // of the seed being searched
  int best_seed_support_ = 0;  // of the seed below which the best interpretation was found
  bool found_ = false;                // the current seed's search found a complete interpretation
  struct {
    int matched = 0, context = 0, support = 0;
    std::vector<int> assignment;
    Values mean;
  } partial_;                    // the branch with the most matches, while no leaf is found
  int max_nulls_ = 0;            // of the current round of iterative deepening
  std::vector<Resume> waiting_;  // null branches the round could not take
  bool overflow_ = false;        // more than kMaxWaiting of them
  std::vector<std::pair<int, std::vector<std::pair<int, double>>>> trace_prefix_;
  mutable std::vector<double> gates_;  // Gate(dof), -1 until computed
  double extent_ = 1;
  SymmetricReadings symmetries_;
  double clutter3_ = 0, clutter2_ = 0;
  double gate3_ = 0, gate2_ = 0;
  std::vector<int> preassigned_;  // per level: the seed's measurement, or -1
  std::vector<int> assignment_;   // per level on the current branch
  long p3p_calls_ = 0;
  std::vector<BlockKind> block_kinds_;  // per block id
  // For the constraints of occluded points fused together: iterations that have not settled
  // within 20 do not (the point is determined only at second order).
  FusionOptions joint_fusion_{.max_iterations = 20};
  mutable std::optional<Grid> grid3_, grid2_;
  mutable std::map<int, std::vector<Rigid3d>> sweeps_;                 // JointSweep, by joint
  mutable std::vector<std::vector<int>> joints_of_;  // per component, its joints (Support)
  mutable std::map<int, std::vector<std::vector<int>>> levels_of_;  // LevelsOf, by plan
  mutable Eigen::MatrixXd distance_;  // between 3D measurements (index3_), for seeds
  mutable Eigen::VectorXd sigma2_;    // their largest variances
  mutable double max_trace3_ = -1;    // the largest trace of a 3D measurement's covariance
  Eigen::VectorXd sigma2_image_;      // the same for image measurements (index2_)
  mutable double diagonal_ = 1000;
};

}  // namespace

FusionPlan PlanCache::Plan(bool image, const PlanStart* start,
                           const std::function<FusionPlan()>& make) const {
  auto key = std::make_tuple(image, start ? start->components : std::vector<int>{-1},
                             start ? start->features : std::vector<int>{});
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = plans_.find(key); it != plans_.end()) return it->second;
  }
  FusionPlan plan = make();
  std::lock_guard<std::mutex> lock(mutex_);
  return plans_.emplace(std::move(key), std::move(plan)).first->second;
}

std::vector<std::array<int, 3>> PlanCache::Triangles(
    bool between_components, const std::function<std::vector<std::array<int, 3>>()>& make) const {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = triangles_.find(between_components); it != triangles_.end()) return it->second;
  }
  std::vector<std::array<int, 3>> triangles = make();
  std::lock_guard<std::mutex> lock(mutex_);
  return triangles_.emplace(between_components, std::move(triangles)).first->second;
}

Interpretation Interpret(const ConstraintGraph& graph, const MeasurementSet& set,
                         const InterpretOptions& options) {
  RequireEstimable(graph);
  // Labels do not steer the search, but a label naming no model point is a mistake in the file.
  ResolveLabels(graph, set);
  if (set.points.size() > static_cast<size_t>(kMaxInterpretedPoints)) {
    throw InputError(SourceLocation(set.source),
                     fmt::format("{} measurements: interpretation takes at most {} (its time and "
                                 "memory grow with their square); crop or subsample the data",
                                 set.points.size(), kMaxInterpretedPoints));
  }
  Interpretation out;
  std::vector<bool> use(graph.constraints.size(), true);
  if (!options.use_constraints_between_components) {
    for (size_t k = 0; k < graph.constraints.size(); ++k) {
      use[k] = ConstraintComponents(graph, graph.constraints[k]).size() <= 1;
    }
  }
  Interpreter search(graph, set, options, use);
  search.Run();
  out.plan = search.best_plan();
  out.stats = search.stats_;
  out.stats.levels = static_cast<int>(out.plan.levels.size());
  out.matches.assign(set.points.size(), "");
  out.assignment.assign(out.plan.levels.size(), -1);
  if (search.best_matched_ < 0) return out;
  out.assignment = search.best_assignment_;
  out.total_delta = search.best_delta_;
  std::optional<Solution> solution;
  // Not for a branch the budget cut short: its estimate, from a few matches, would re-associate
  // the rest to clutter (lamps at 30 % occlusion: 59 % of matches right without, 11 % with).
  if (options.refine_rounds > 0 && search.complete_) {
    solution = search.Refine(&out.assignment, options.refine_rounds, &out.stats.refinements);
  }
  // The matches, and each level's choice in the trace, from the assignment.
  auto record = [&] {
    out.matches.assign(set.points.size(), "");
    out.matched = 0;
    for (size_t l = 0; l < out.plan.levels.size(); ++l) {
      const PlanLevel& p = out.plan.levels[l];
      out.trace[l].chosen = out.assignment[l];
      if (out.assignment[l] >= 0) {
        out.matches[out.assignment[l]] = ModelPointName(graph, p.component, p.feature);
        ++out.matched;
      }
    }
  };
  for (size_t l = 0; l < out.plan.levels.size(); ++l) {
    const PlanLevel& p = out.plan.levels[l];
    TraceLevel t;
    t.constraints = p.constraints;
    t.component = p.component;
    t.feature = p.feature;
    t.best = search.best_trace_[l];
    out.trace.push_back(std::move(t));
  }
  record();
  if (out.matched > 0) {
    out.solution =
        solution ? std::move(solution) : search.SolveLabelling(out.assignment, search.best_mean_);
    // An answer the fit test rejects can be a reading of the right one that the data only
    // nearly allow (a folding ruler read from its other end, each segment turned end for end
    // with its corners 3 mm off): the best accepted reading replaces it.
    if (!out.solution->accepted() && options.max_symmetric_readings > 0) {
      std::vector<Interpreter::Found> readings = search.SymmetricAlternatives(
          *out.solution, out.assignment, options.max_symmetric_readings);
      const auto best = std::min_element(
          readings.begin(), readings.end(), [](const auto& a, const auto& b) {
            return a.solution.analysis.fit.chi2 < b.solution.analysis.fit.chi2;
          });
      if (best != readings.end()) {
        // Re-associated under its own estimate: points the wrong reading left unmatched can
        // find their measurements now.
        std::vector<int> assignment = best->assignment;
        if (options.refine_rounds > 0) {
          search.best_mean_ = best->solution.state.mean;
          int changes = 0;
          Solution refined = search.Refine(&assignment, options.refine_rounds, &changes);
          if (refined.accepted()) {
            best->solution = std::move(refined);
            best->assignment = std::move(assignment);
            out.stats.refinements += changes;
          }
        }
        *out.solution = std::move(best->solution);
        out.assignment = std::move(best->assignment);
        record();
      }
    }
    if (out.solution->accepted() &&
        (options.max_alternative_seeds > 0 || options.max_symmetric_readings > 0)) {
      std::vector<Interpreter::Found> others =
          search.Alternatives(out.solution->state, options.max_alternative_seeds);
      for (Interpreter::Found& other : search.SymmetricAlternatives(
               *out.solution, out.assignment, options.max_symmetric_readings)) {
        others.push_back(std::move(other));
      }
      // One that matches as many points in the same plan and fits better is the answer: the
      // data tell them apart (a folding ruler read from its other end fits, but worse).
      for (Interpreter::Found& other : others) {
        // (By more than rounding: an exact symmetry's reading fits the same.)
        const double chi2 = out.solution->analysis.fit.chi2;
        if (other.same_plan && other.solution.analysis.fit.chi2 < chi2 - 1e-9 * (1 + chi2)) {
          Solution previous = std::move(*out.solution);
          *out.solution = std::move(other.solution);
          other.solution = std::move(previous);
          std::swap(out.assignment, other.assignment);
          record();
        }
      }
      // Each distinct answer once: a reading of the answer can repeat what a seed found.
      std::vector<const GaussianState*> listed = {&out.solution->state};
      const double extent = ModelExtent(graph);
      for (const Interpreter::Found& other : others) {
        const bool seen = std::any_of(listed.begin(), listed.end(), [&](const GaussianState* s) {
          return !Distinct(graph, other.solution.state.mean, *s, extent);
        });
        if (seen) continue;
        listed.push_back(&other.solution.state);
        out.solution->alternatives.push_back(
            {other.solution.state.mean, other.solution.analysis.fit});
      }
      // The statistics count the search for alternatives too.
      const int refinements = out.stats.refinements;
      out.stats = search.stats_;
      out.stats.levels = static_cast<int>(out.plan.levels.size());
      out.stats.refinements = refinements;
    }
  }
  out.stats.predicted = search.image() ? search.best_predicted_ : -1;
  return out;
}

std::string Interpretation::Refusal() const {
  if (!solution) return "no measurement matches a model point";
  if (!solution->accepted()) return "the estimate from the matches is not accepted";
  // A search the budget cut short has not compared its best with the rest: unless that best
  // accounts for all model points but kLazyNulls (where a complete search stops too), a better
  // interpretation may lie in what it did not see.
  if (stats.status == SearchStats::Status::kBudget &&
      matched < static_cast<int>(assignment.size()) - kLazyNulls) {
    return fmt::format("the node budget ended the search with {} of {} model points matched: "
                       "the best interpretation so far is written, unverified (raise "
                       "--max-nodes, or crop the data)",
                       matched, assignment.size());
  }
  if (!solution->undetermined.empty()) {
    std::string names;
    for (const std::string& n : solution->undetermined) names += (names.empty() ? "" : ", ") + n;
    return fmt::format("the {} matches leave {} undetermined: too few to tell the object from "
                       "clutter",
                       matched, names);
  }
  if (solution->analysis.fit.dof < 1) {
    return fmt::format("the {} matches fit exactly, with no residual degrees of freedom: any {} "
                       "points would, so they cannot tell the object from clutter",
                       matched, matched);
  }
  // From an image, the first matches fix the pose and any clutter fits them; only a match
  // predicted where clutter is unlikely is evidence. The scissors among as many clutter
  // points were accepted with 4 or 5 matches, 0 to 2 of them predicted, every one wrong (0.1 to
  // 0.6 m off); right answers had at least 4 (bench/answer_sweep).
  if (stats.predicted >= 0 && stats.predicted < kMinPredicted) {
    return fmt::format("only {} of the {} matches were predicted before they were seen (the "
                       "others fix the pose, and clutter would fit them as well): too few to "
                       "tell the object from clutter",
                       stats.predicted, matched);
  }
  return "";
}

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
