// The interpretation tree's search (Hel-Or & Werman's tree with constraint fusion, Lowe's match
// probabilities), in parts: the search state and its seeds (interpreter_seeds.cpp), the tree
// itself (interpreter_search.cpp), gating and scoring of candidates (interpreter_gating.cpp), and
// the refinement of the best labelling against its own estimate (interpreter_refine.cpp).
// interpretation.cpp drives it for the public Interpret(). Internal to interp: not installed.
#pragma once

#include <Eigen/Core>
#include <array>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "cfuse/interp/interpretation.h"
#include "point_grid.h"
#include "symmetric_readings.h"

namespace cfuse::internal {

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

Eigen::Vector3d NominalWorld(const ConstraintGraph& g, ModelPointRef p);

// The measurement function of model point `p` against measurement `m`, or with a zero
// measurement (`m` < 0) for predictions: a 3D point, or an image point when `image`.
Factor MeasurementFactor(const ConstraintGraph& g, const MeasurementSet& set, ModelPointRef p,
                         int m, bool image);

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
  int support = 0;  // model points with a measurement near their seeded position
  // At most this many points can match below the seed: its own component's supported points,
  // those of each component joined to it that its joint's sweep brings near a measurement,
  // and every point of the others, whose places the seed does not fix (Support).
  int bound = 0;
  // Per component: where the search starts it, as a motion of the nominal geometry (the seed's
  // pose, and for components beyond joints the best of each joint's sweep: Support).
  std::vector<Rigid3d> placement;
  double residual = 0;  // of the seed's own geometry, normalised
};

double LargestVariance(const Eigen::MatrixXd& cov);

// The median of the 3D measurements' largest standard deviations (0 without any).
double TypicalNoise(const MeasurementSet& set);

class Interpreter {
 public:
  Interpreter(const ConstraintGraph& g, const MeasurementSet& set, const InterpretOptions& options,
              std::vector<bool> use);

  const FusionPlan& best_plan() const { return contexts_[best_context_].plan; }
  bool image() const { return image_; }

  // The estimate from a labelling of the best plan's levels, started at `start` (the tree's
  // estimate, which has every point, occluded ones included, near its place; the closed-form
  // starts of solve.h place occluded points of a moved part at the nominal geometry).
  Solution SolveLabelling(const std::vector<int>& assignment, const Values& start) const;

  // The same from `start`, or from solve.h's own starts when null.
  Solution SolveFrom(const std::vector<int>& assignment, const Values* start) const;

  // Refines the best labelling against its own estimate (see "Refinement" below), at most
  // `rounds` times; returns the estimate of the final labelling and the number of changes.
  Solution Refine(std::vector<int>* assignment, int rounds, int* changes) const;

  // Refine's proposals, each handed to `try_labelling`, which keeps one that scores higher:
  // two matched points close together in the image, each inside the other's gate, swapped.
  template <typename Try>
  bool SwapClosePairs(Try& try_labelling, const GaussianState& state,
                      const std::vector<int>& assignment) const;

  // 3D data: a matched measurement nearer an unmatched point of its component than twice the
  // two points' distance, moved to that point (the likeliest kMaxShifts first).
  template <typename Try>
  bool ShiftToUnmatched(Try& try_labelling, const GaussianState& state,
                        const std::vector<int>& assignment) const;

  // A match moved to an unmatched point whose gate holds it.
  template <typename Try>
  bool MoveToUnmatched(Try& try_labelling, const GaussianState& state,
                       const std::vector<int>& assignment) const;

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
  std::vector<Found> Alternatives(const GaussianState& answer, int max_seeds);

  // The answer read by the model's symmetries (symmetric_readings.h): the same points with
  // congruent parts exchanged or a symmetric part turned onto itself. Each reading's labelling
  // is re-fitted from the reading, and returned, as Alternatives does, when its estimate is
  // accepted and distinct from the answer. Readings whose constraints are broken by more than
  // 2 % of the model's size (or 0.02 rad) are not tried: no re-fit repairs that much.
  std::vector<Found> SymmetricAlternatives(const Solution& answer,
                                           const std::vector<int>& assignment,
                                           int max_readings) const;

  // Searches below each seed, most supported first, by iterative deepening on null branches:
  // round k allows k of them, and the first complete interpretation found below a seed ends
  // its search (it has the most matches that seed allows: every round before failed). A later
  // seed is searched only if its bound (its supported points, and those of other components,
  // whose places it does not fix) could still beat that interpretation, and, once that leaves
  // at most kLazyNulls points unmatched, its support too; it must then match more points.
  // Without seeds, the same from the nominal geometry (the paper's search).
  void Run();

  // Seed sets are opened one at a time (each costs its measurement triples), and a set's clear
  // winner (support of at least 4 points, or a sixth of them, and 2 more than the set's next
  // seed; a seed from clutter finds 0-2) is searched at once; once an interpretation with at
  // most kLazyNulls unmatched points is found, no further set is opened. Otherwise every seed
  // of every set competes, most supported first, as above.
  void Explore();

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
  FusionPlan Plan(const PlanStart* start) const;

  Context MakeContext(FusionPlan plan) const;

  // The context whose plan starts with seed set `s`.
  int ContextFor(const std::vector<ModelPointRef>& s);

  // ---- Seeds ------------------------------------------------------------------------------

  // Sets of plan levels from which a pose follows in closed form: up to kMaxSeedSets rigid
  // triangles of single points (best smallest side first, each point in at most two), and per
  // rigid component its best-spread feature triples (with a fourth feature for image data).
  std::vector<std::vector<ModelPointRef>> SeedSets(bool image) const;

  // Up to kMaxSeedSets rigid triangles (schedule.h), best-shaped first, each point in at most
  // two of them, so that one occluded point does not take every seed set with it.
  std::vector<std::array<int, 3>> SeedTriangles() const;

  // Hypotheses for every seed set, most supported first.
  // Appends the hypotheses of seed set `s`.
  void Seeds(const std::vector<ModelPointRef>& s, std::vector<Seed>* seeds);

  // 3D: measurement triples whose pairwise distances match the seed's within the gate.
  void PointSeeds(const std::vector<ModelPointRef>& s, int context, std::vector<Seed>* seeds) const;

  // 2D: P3P on ordered triples of image points, checked by the fourth seed point.
  void ImageSeeds(const std::vector<ModelPointRef>& s, int context, std::vector<Seed>* seeds);

  // The motions (in the nominal world) that joint `j`'s range gives its child with the parent
  // held, sampled finely enough that no point of either moves more than the support radius
  // between samples; empty where that takes too many samples or the joint has no variable.
  const std::vector<Rigid3d>& JointSweep(int j) const;

  // Model points, placed at the seed's pose, that have a measurement within 5 % of the extent
  // (3D) or 3 % of the image diagonal (2D); and the most points that could match below the
  // seed. The seed's own component is placed rigidly; a component joined to a placed one by a
  // joint with a variable is placed where the joint, swept over its range, puts the most of
  // its points near a measurement (the nominal joint value says little: the joint moved), and
  // the search starts there; the rest keep the nominal geometry. The bound rules out the own
  // component's points away from every measurement, and a joined component's points that no
  // place along its joint's sweep brings near one; components farther along a chain may sit
  // anywhere their joints allow.
  void Support(Seed* seed_out, bool image) const;

  // A seed's own noise leaves it turned about its weakest axis by σ / sqrt(λ), λ the
  // smallest eigenvalue of Σ |q|² I - q qᵀ over its centred points q (3D). A thin seed (a
  // blade's pivot, tip and ring, 12 mm off one line) turns by 0.2 rad for 2 mm of noise, and
  // a joint swept from it passes its neighbour's points by centimetres: the tree then starts
  // the neighbour far from its points, its linearised gates miss them, and the bound rules
  // out the seed that holds the answer. TurnedStarts gives the seed's pose also turned within 3
  // sigmas, in steps that move the model's farthest point by the sweep's radius: the placing that
  // brings the most points near starts the search, and the bound counts every point that
  // one of them brings near.
  std::vector<Rigid3d> TurnedStarts(const Seed& seed, const Context& ctx) const;

  // Per component, the plan levels of its points in plan `context`.
  const std::vector<std::vector<int>>& LevelsOf(int context) const;

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

  void Search(const Seed* seed);

  // A frame whose remaining candidates are to be searched, with the branch above it.
  struct Resume {
    Frame frame;
    std::vector<std::pair<int, std::vector<std::pair<int, double>>>> trace;  // (level, best3)
    std::vector<int> assignment;
  };
  static constexpr size_t kMaxWaiting = 1024;

  // Depth first below r's frame, within the round's null branches.
  void SearchBelow(Resume r);

  // The chi-square quantile at the gate confidence for `dof` degrees of freedom, computed once
  // per dof and confidence in a thread: the tests below ask for it at every node, and a
  // tracker interprets frame after frame at one confidence.
  double Gate(int dof) const;

  bool JointlyCompatible(const Frame& f) const;

  // Fuses `list` into f's state; false when a constraint contradicts what was fused before it,
  // fails, or its innovation NIS is outside the chi-square gate for its rows. Adds the NIS to
  // *nis.
  bool FuseConstraints(const std::vector<int>& list, Frame* f, double* nis) const;

  // Whether a constraint's fusion is consistent: not refused, converged, and its innovation
  // NIS inside the chi-square gate for its rows (then added to the branch's and to *nis).
  bool Accept(const FusionSummary& s, Frame* f, double* nis) const;

  // Fuses the deferred constraints of each occluded point that can now be placed: re-centred
  // on its matched neighbours (Recentre), every deferred constraint on it whose other
  // components are matched. False when one of them is inconsistent.
  bool FuseDeferred(Frame* f) const;

  // At a leaf: the constraints still waiting on occluded points, fused together as one factor
  // (each such point first re-centred on its neighbours) and tested, so that every constraint
  // has checked the matches before the leaf counts. False when they disagree with them.
  bool FuseRemaining(Frame* f) const;

  // Moves single point `component` (re-centred near its place) to where constraints `list`
  // hold best with everything else fixed: Levenberg-Marquardt on the sum of their squared
  // residuals. The re-centring maps the nominal geometry rigidly onto matched neighbours that
  // may belong to parts turned about a joint between them, which can leave the point
  // centimetres off; linearised there, its constraints would disagree with matches that are
  // right. False when the residuals are not finite.
  bool Place(const std::vector<int>& list, int component, Frame* f) const;

  // Whether constraints `list` determine single point `component` where it is now guessed:
  // their rows, each scaled to a unit gradient in the point, span all three directions well
  // (smallest singular value above 0.1). Two distances leave it a circle; three whose centres
  // are coplanar with it meet there only tangentially. Either way its place would be the
  // guess's, and the constraints fused there would pin it wrongly.
  bool Determine(const std::vector<int>& list, int component, const Frame& f) const;

  // Whether component c has a match on f's branch (a seed's or a level's).
  bool IsMatched(const Frame& f, int c) const;

  // Sets up f for its level: fuses the level's constraints that do not touch its component,
  // keeps the others for after the match, and lists the candidates.
  bool EnterLevel(Frame* f) const;

  // Where the filter linearises an unmatched component decides what its constraints predict.
  // The seed placed the whole nominal model rigidly, which is far off for parts beyond a few
  // joints; so while the component is still untouched by any fusion (its mean is free under
  // the vague prior), it is placed with the nominal geometry relative to its matched
  // neighbours: the rigid motion of a matched rigid neighbour, or the one that best maps three
  // or more matched neighbouring points onto their estimates.
  bool Recentre(Frame* f, int component) const;

  // The level's candidates, best first, and the null branch:
  //  (A) unused measurements inside the gate around the point predicted with every constraint
  //      of the level fused (linearised where the point is now guessed);
  //  (B) for a single point, the other unused measurements at which each own constraint,
  //      evaluated exactly with the point moved there, is within its gate: they lie on the
  //      constraints' curved locus (a sphere, a circle) beyond the linear prediction.
  void BuildCandidates(Frame* f) const;

  // Whether f's level is a single point whose every own constraint (those linking it to the
  // points matched before it) waits on an occluded point: its prediction is the vague prior.
  bool Blind(const Frame& f) const;

  // δ = (p - z)ᵀ (P + Λ)⁻¹ (p - z) and log det(P + Λ) for an N-vector measurement, in fixed
  // sizes: this runs for every measurement at every level. False when the prediction has
  // another size or P + Λ is not positive definite.
  template <int N>
  static bool Mahalanobis(const Prediction& p, const Eigen::Matrix<double, N, 1>& z,
                          const Eigen::Matrix<double, N, N>& noise, double* delta, double* log_det);

  // Measurement m against a prediction of its model point: its δ, Lowe's probability and
  // whether the gate is informative; nothing when outside the gate (unless not `gated`).
  std::optional<Candidate> Score(const Prediction& p, int m, bool gated = true) const;

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
  std::vector<int> Reassociate(int context, const GaussianState& state) const;

  // The total log(p/q) of a labelling under `state` (no gate: a match far off scores low).
  double LabellingScore(int context, const std::vector<int>& assignment,
                        const GaussianState& state) const;

  // The point's prediction once the level's own constraints are fused, computed on the
  // marginal of the blocks they and the point touch rather than on a copy of the whole state:
  // conditioning on constraints over a set of blocks changes that set's marginal through that
  // marginal alone, so the prediction is the same (the lamp's 69 coordinates against 12 or so:
  // a tenth of the interpretation's time).
  std::pair<Prediction, Prediction> PredictWithOwn(const Frame& f, ModelPointRef point) const;

  std::pair<Prediction, Prediction> PredictPoint(ModelPointRef point,
                                                 const GaussianState& state) const;

  std::vector<Candidate> LocusCandidates(const Frame& f, const std::vector<bool>& used,
                                         const std::vector<bool>& listed) const;

  void Leaf(const Frame& f, const std::vector<Frame>& path);

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
  int seed_support_ = 0;              // of the seed being searched
  int best_seed_support_ = 0;         // of the seed below which the best interpretation was found
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
  mutable std::map<int, std::vector<Rigid3d>> sweeps_;  // JointSweep, by joint
  mutable std::vector<std::vector<int>> joints_of_;     // per component, its joints (Support)
  mutable std::map<int, std::vector<std::vector<int>>> levels_of_;  // LevelsOf, by plan
  mutable Eigen::MatrixXd distance_;  // between 3D measurements (index3_), for seeds
  mutable Eigen::VectorXd sigma2_;    // their largest variances
  mutable double max_trace3_ = -1;    // the largest trace of a 3D measurement's covariance
  Eigen::VectorXd sigma2_image_;      // the same for image measurements (index2_)
  // The image measurements binned by where they lie, cells as wide as the widest gate: the
  // fourth point of every P3P pose looks in the 3 x 3 cells about it, not at every measurement.
  struct ImageBins {
    double cell = 1;
    int columns = 1, rows = 1;
    Eigen::Vector2d origin = Eigen::Vector2d::Zero();
    std::vector<int> start, entries;  // per cell, its first entry; entries in index2_'s order
  };
  ImageBins image_bins_;
  std::vector<Eigen::Vector3d> bearings_;  // per image measurement (index2_), for P3P
  mutable double diagonal_ = 1000;
};

}  // namespace cfuse::internal
