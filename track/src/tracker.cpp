#include "cfuse/track/tracker.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "cfuse/constraints/dof.h"
#include "cfuse/constraints/evaluate.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/error.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

// The robust scale of `distance` (1.4826 times its median: a Gaussian's standard deviation),
// held within [lo, hi]; lo for none.
double RobustScale(std::vector<double> distance, double lo, double hi) {
  if (distance.empty()) return lo;
  std::nth_element(distance.begin(), distance.begin() + distance.size() / 2, distance.end());
  return std::clamp(1.4826 * distance[distance.size() / 2], lo, hi);
}

// Iteratively reweighted least squares' step, by Tukey's biweight at 4.685 robust standard
// deviations (ViSP's estimator): distance[j] (of measurement used[j]) sets weight[used[j]], 0
// past it. Returns the scale (RobustScale within [lo, hi]); `change` rises to the largest change
// of a weight.
double TukeyReweight(const std::vector<double>& distance, const std::vector<int>& used, double lo,
                     double hi, std::vector<double>* weight, double* change) {
  const double scale = RobustScale(distance, lo, hi);
  for (size_t j = 0; j < used.size(); ++j) {
    const double x = distance[j] / (4.685 * scale);
    const double w = x < 1 ? (1 - x * x) * (1 - x * x) : 0.0;
    *change = std::max(*change, std::abs(w - (*weight)[used[j]]));
    (*weight)[used[j]] = w;
  }
  return scale;
}

}  // namespace

double Tracker::PositionSigma(const GaussianState& state,
                              const std::vector<EdgeModel>& visible) const {
  double worst = 0;
  for (const EdgeModel& e : visible) {
    const Block& block = graph_.blocks[e.block];
    const Eigen::Matrix<double, 6, 6> s =
        state.covariance.block<6, 6>(block.tangent_offset, block.tangent_offset);
    const Eigen::Matrix3d R = state.mean.poses[block.index].RotationMatrix();
    for (const Eigen::Vector3d& p : {e.A, e.B}) {
      Eigen::Matrix3d skew;
      skew << 0, -p.z(), p.y(), p.z(), 0, -p.x(), -p.y(), p.x(), 0;
      Eigen::Matrix<double, 3, 6> J;  // ∂(R p + t) / ∂[δθ; δt]
      J << -R * skew, Eigen::Matrix3d::Identity();
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(J * s * J.transpose(),
                                                                 Eigen::EigenvaluesOnly);
      worst = std::max(worst, std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff())));
    }
  }
  return worst;
}

double Tracker::Spread(const GaussianState& before, const GaussianState& after) const {
  double worst = 0;
  for (const Component& c : graph_.components) {
    if (!c.rigid) continue;
    const int o = graph_.blocks[c.block].tangent_offset;
    const Eigen::Matrix<double, 6, 6> prior = before.covariance.block<6, 6>(o, o);
    const Eigen::Matrix<double, 6, 6> posterior = after.covariance.block<6, 6>(o, o);
    // The largest ratio of variances along any direction: the generalised eigenvalues of
    // (posterior, prior).
    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> ratio(
        posterior, prior, Eigen::EigenvaluesOnly);
    if (ratio.info() != Eigen::Success) return 1;
    worst = std::max(worst, std::sqrt(std::max(0.0, ratio.eigenvalues().maxCoeff())));
  }
  return worst;
}

Tracker::Tracker(const ConstraintGraph& graph, const Camera& camera, const Values& initial,
                 TrackerOptions options)
    : graph_(graph), camera_(camera), options_(std::move(options)) {
  CheckGraph(graph_);
  CheckValuesFit(graph_.blocks, initial);
  if (camera_.width <= 0 || camera_.height <= 0) {
    throw InputError(SourceLocation(), "the camera has no image size (width and height)");
  }
  edges_ = ModelEdges(graph_);
  depth_faces_ = DepthFaces(graph_);
  appearance_ = EdgeAppearance(static_cast<int>(edges_.size()));
  for (const Constraint& c : graph_.constraints)
    constraints_.push_back({c.residual, c.blocks, {}, c.name});
  const DofReport dof = AnalyzeDof(graph_, graph_.nominal);
  if (dof.computed) dof_ = dof.dof;
  radius_.assign(graph_.blocks.size(), 0.0);
  for (const Component& c : graph_.components) {
    if (!c.rigid || c.points.empty()) continue;
    double sum = 0;
    for (const auto& p : c.points) sum += p.position.squaredNorm();
    radius_[c.block] = std::sqrt(sum / static_cast<double>(c.points.size()));
  }
  // The start's slacks from its poses: a limit's slack left at the nominal geometry's value
  // would pull the joint there as soon as the limit is fused.
  Values start = initial;
  MatchSlacks(graph_, &start);
  history_ = {{0, start}};
  model_sigma_ = options_.pixel_sigma;
}

Values Tracker::Predicted() const {
  const auto& [last_frame, last] = history_.back();
  Values predicted = last;
  if (history_.size() >= 2) {
    // The velocity of the last two verified frames, per frame, in each block's chart, carried
    // on to this frame (the object moves on while it is lost), at most `max_extrapolation`
    // frames ahead: a velocity is only as good as the frames it came from.
    const auto& [first_frame, first] = history_.front();
    const Eigen::VectorXd step = LocalCoordinates(graph_.blocks, first, last) /
                                 static_cast<double>(last_frame - first_frame);
    const int ahead = std::min(frame_ - last_frame, options_.max_extrapolation);
    Retract(graph_.blocks, step * static_cast<double>(ahead), &predicted);
  }
  return predicted;
}

FramePrior Tracker::Prior(const Values& predicted, double scale) const {
  // A slack is pinned by its inequality; its prior only must not constrain it (a vaguer one
  // loses the variance it ends with to cancellation).
  GaussianState prior = MakePrior(graph_.blocks, predicted, PriorScale{1, 1, 10});
  // The last motion per block, carried as far ahead as the prediction is.
  Eigen::VectorXd motion = Eigen::VectorXd::Zero(prior.dim());
  if (history_.size() >= 2) {
    const auto& [first_frame, first] = history_.front();
    const auto& [last_frame, last] = history_.back();
    const double ahead = std::min(frame_ - last_frame, options_.max_extrapolation);
    motion = LocalCoordinates(graph_.blocks, first, last) *
             (ahead / static_cast<double>(last_frame - first_frame));
  }
  const double reach = options_.search_pixels / 3;  // px, one standard deviation
  for (size_t b = 0; b < graph_.blocks.size(); ++b) {
    const Block& block = graph_.blocks[b];
    const int o = block.tangent_offset;
    if (block.kind == BlockKind::kSlack) continue;
    const Eigen::Vector3d t = block.kind == BlockKind::kPose
                                  ? predicted.poses[block.index].translation
                                  : predicted.points[block.index];
    // Each translation moves the image `reach` px at the block's depth.
    const double pixels = PixelsPerMetre(t.z());
    const int t_offset = block.kind == BlockKind::kPose ? o + 3 : o;
    const double sigma_t = scale * std::max(reach / pixels, options_.motion_share *
                                                                motion.segment<3>(t_offset).norm());
    prior.prior_variance.segment<3>(t_offset).setConstant(sigma_t * sigma_t);
    if (block.kind == BlockKind::kPose) {
      // ... and each turn moves the component's points `reach` px at their RMS distance from
      // its origin.
      const double sigma_r = scale * std::max(reach / (pixels * std::max(radius_[b], 1e-3)),
                                              options_.motion_share * motion.segment<3>(o).norm());
      prior.prior_variance.segment<3>(o).setConstant(sigma_r * sigma_r);
    }
  }
  prior.covariance = prior.prior_variance.asDiagonal();
  FramePrior out{prior, prior};
  // The equalities only: a limit fused where its range's gradient vanishes (a joint at the
  // middle of its range) pins its slack and says nothing of the joint. The solve fuses every
  // constraint, the limits with the data.
  for (size_t c = 0; c < constraints_.size(); ++c) {
    if (graph_.constraints[c].slack_block < 0) Fuse(constraints_[c], &out.constrained);
  }
  return out;
}

TrackedFrame Tracker::Track(const GrayView& image, const DepthFrame& depth) {
  if (depth.width <= 0 || depth.height <= 0 ||
      depth.points.size() != static_cast<size_t>(depth.width) * depth.height) {
    throw InputError(SourceLocation(),
                     fmt::format("the depth frame holds {} points, not its {} x {}",
                                 depth.points.size(), depth.width, depth.height));
  }
  depth_ = &depth;
  try {
    TrackedFrame out = Track(image);
    depth_ = nullptr;
    return out;
  } catch (...) {
    depth_ = nullptr;
    throw;
  }
}

TrackedFrame Tracker::Track(const GrayView& image) {
  if (image.width != camera_.width || image.height != camera_.height) {
    throw InputError(SourceLocation(), "the image is " + std::to_string(image.width) + " x " +
                                           std::to_string(image.height) + ", the camera's " +
                                           std::to_string(camera_.width) + " x " +
                                           std::to_string(camera_.height));
  }
  const Values predicted = Predicted();
  TrackedFrame out;
  best_outline_ = 0;
  undetermined_.reset();
  // The search range grows with the frames since the last verified one (the prediction is that
  // much older), then doubles on failure.
  const int lost = last_verified_ < 0 ? 0 : std::max(0, frame_ - last_verified_ - 1);
  const double base = std::min<double>(1 + lost, options_.max_lost_growth);
  GaussianState first_prior;  // the prediction, for a lost frame's estimate
  // A range that verifies only a set far less supported than the sequence's verified frames
  // (a box slid along its parallel edges, the right place beyond the range) is doubled too,
  // and the better supported of the two kept.
  auto weak = [&](const TrackedFrame& f) {
    return !f.verified || f.verification.share < 0.9 * typical_share_;
  };
  // A track's second frame, with one verified frame behind and no velocity yet: the prediction
  // is the last pose, and a moving object may be beyond a still one's range, its estimate
  // pulled toward the prediction into a nearby minimum that the outline supports as well
  // (Castle-simu from its true pose at frame 11: frame 12 verified 10 mm deep). The doubled
  // range is tried whatever the first verified, and kept when its outline is clearly better
  // supported. (Also after a frame that broke with the motion, it was tried: a lid in view
  // again after an occlusion took a wider range's clutter, 108 degrees off, for 35 frames.)
  const bool unknown_motion = options_.unknown_motion_share > 0 && verified_frames_ == 1 &&
                              last_verified_ == frame_ - 1 && history_.size() < 2;
  for (int d = 0; d <= options_.max_doublings && (weak(out) || (unknown_motion && d == 1)); ++d) {
    const auto start = Clock::now();
    const FramePrior prior = Prior(predicted, base * std::ldexp(1.0, d));
    out.times.prediction += Ms(start, Clock::now());
    if (d == 0) first_prior = prior.constrained;
    TrackedFrame attempt;
    attempt.doublings = d;
    TryFrom(image, prior, &attempt);
    FrameTimes spent = out.times;
    spent += attempt.times;
    const int branches = out.branches + attempt.branches;
    const double better = unknown_motion && d == 1 ? options_.unknown_motion_share : 1.0;
    if (d == 0 || (attempt.verified && (!out.verified || attempt.verification.share >
                                                             better * out.verification.share))) {
      out = std::move(attempt);
    } else if (!out.verified && !attempt.verification.why.empty()) {
      out.verification = std::move(attempt.verification);  // a wider range's reason
    }
    out.times = spent;
    out.branches = branches;
  }
  // Lost for a frame or more: places in rings about the last pose carried (and about the last
  // verified one when the carried estimate has strayed from it), a ring further out each frame
  // (round again once the rings leave the image), the best of the first ring that finds the
  // object kept. (The same search at the first frame, keeping the estimate that explains the
  // most of the outline, was tried against starts far off: it found more frames but verified
  // more wrong ones, and moved castel's track by 12 mm.)
  if (!out.verified && lost > 0 && ReacquireLost(image, &out)) out.reacquired = true;
  if (out.verified && (last_verified_ < 0 || lost > 0 || out.reacquired)) Settle(image, &out);
  // A pose the outline supports better but its matches leave undetermined (an occluder hides
  // what would fix it) against a worse-supported one that is determined: the second has taken
  // lines that are not the object's (an occluder's own edges) to be determined. Neither is the
  // frame's answer.
  if (out.verified && out.verification.share < options_.min_share_of_best * best_outline_) {
    out.verified = false;
    out.verification.verified = false;
    out.verification.refusal = Refusal::kOutdone;
    out.verification.why = fmt::format(
        "a pose the outline supports better ({:.0f} % against {:.0f} %) is left undetermined by "
        "its matches",
        100 * best_outline_, 100 * out.verification.share);
  }
  if (out.verified) {
    ++verified_frames_;
    reacquisition_ring_ = 0;
    Remember(out.verification, &appearance_);
    // The model's error is learnt from frames as well supported as the sequence's best: one
    // sliding off the object would widen every later frame's tolerance.
    const bool confident = out.verification.agreement >= 0.9 * typical_agreement_;
    typical_agreement_ =
        std::max(out.verification.agreement, options_.typical_decay * typical_agreement_);
    typical_share_ = std::max(out.verification.share, options_.typical_decay * typical_share_);
    if (confident && out.model_sigma > 0) {
      model_sigma_ = std::clamp(0.7 * model_sigma_ + 0.3 * out.model_sigma, options_.pixel_sigma,
                                options_.max_model_sigma);
    }
    // (the initial configuration is frame 0's guess: frame 0's estimate replaces it)
    if (history_.back().first == frame_) history_.pop_back();
    // A frame found only by doubling the range or away from the prediction broke with the
    // motion so far (a knock, a jerk): the step to it is no velocity to carry on. (With no
    // velocity before it, the step to it is the first.)
    if ((out.doublings > 0 && !unknown_motion) || out.reacquired) history_.clear();
    history_.push_back({frame_, out.estimate.mean});
    if (history_.size() > 2) history_.erase(history_.begin());
    last_verified_ = frame_;
    last_seen_ = out.estimate.mean;
  } else if (undetermined_ &&
             (options_.carry_joints_at_limits || !PushedToLimit(undetermined_->mean, predicted))) {
    // A set passed every test of the outline, its precision alone did not: its estimate is
    // nearer than the prediction (motion blur widens the edges while the object runs on).
    out.estimate = std::move(*undetermined_);
    out.imprecise = true;
    if (history_.back().first == frame_) history_.pop_back();
    history_.push_back({frame_, out.estimate.mean});
    if (history_.size() > 2) history_.erase(history_.begin());
  } else {
    out.estimate = first_prior;
    if (out.verification.refusal == Refusal::kNone) {
      out.verification.refusal = Refusal::kNoMatches;
      out.verification.why = RefusalName(Refusal::kNoMatches);
    }
  }
  ++frame_;
  return out;
}

bool Tracker::TryFrom(const GrayView& image, const FramePrior& prior, TrackedFrame* out) {
  FrameTimes& times = out->times;
  auto start = Clock::now();
  const std::vector<EdgeModel> edges =
      PredictEdges(graph_, edges_, prior.constrained, camera_, options_.visibility, model_sigma_,
                   options_.min_edge_pixels);
  out->predicted.clear();
  for (const EdgeModel& e : edges) {
    PredictedEdge shown;
    shown.edge = e.edge;
    shown.a = e.a;
    shown.b = e.b;
    shown.sigma_a = std::sqrt(e.var_a);
    shown.sigma_b = std::sqrt(e.var_b);
    out->predicted.push_back(shown);
  }
  auto predicted_at = Clock::now();
  times.prediction += Ms(start, predicted_at);
  if (static_cast<int>(edges.size()) < (dof_ + 1) / 2) return false;

  const std::vector<EdgeCandidate> candidates = Candidates(image, edges);
  auto found_at = Clock::now();
  times.segments += Ms(predicted_at, found_at);

  // Branches for each component in view.
  std::vector<bool> in_view(graph_.blocks.size(), false);
  for (const EdgeModel& e : edges) in_view[e.block] = true;
  MatchSearchOptions search = options_.search;
  search.max_branches =
      options_.max_branches *
      std::max<int>(1, static_cast<int>(std::count(in_view.begin(), in_view.end(), true)));
  double verification_ms = 0;
  Verification last_judged, best_judged;
  double best_sigma = 0;
  const MatchSearchResult result = SearchMatchSets(
      graph_, camera_, constraints_, prior, edges, candidates, dof_, search, [&](MatchedSet* set) {
        const auto t = Clock::now();
        Refine(image, prior, set);
        // With a range sensor's points, the estimate sits where the faces' depth puts it, and a
        // model a few pixels off the real object leaves its edges as far off in the image as
        // the edges' own fit found them: the outline is judged at that error.
        const double sigma =
            set->depth_points > 0 ? std::max(model_sigma_, set->model_sigma) : model_sigma_;
        const std::vector<EdgeModel> at =
            PredictEdges(graph_, edges_, set->state, camera_, options_.visibility, sigma,
                         options_.min_edge_pixels);
        // The faces where the range sensor saw them, when it saw enough of them (a sensor
        // that saw nothing there, or only an occluder, says nothing of the pose).
        const DepthAgreement agree =
            depth_ ? AgreeDepth(graph_, depth_faces_, set->state.mean, *depth_, options_.depth)
                   : DepthAgreement{};
        const bool depth_judged = agree.samples >= options_.depth.min_samples;
        VerificationOptions verification = options_.verification;
        if (depth_judged && set->depth_points > 0 &&
            agree.share >= options_.depth.min_inlier_share_weak_outline) {
          verification.min_share = options_.depth.min_outline_share;
          verification.min_dominant = options_.depth.min_outline_dominant;
        }
        Verification v = VerifyOutline(image, at, options_.evidence_options.search, verification,
                                       ModelLines(set->state.mean));
        if (depth_ != nullptr) {
          v.depth_samples = agree.samples;
          v.depth_share = agree.share;
          if (v.verified && depth_judged && agree.share < options_.depth.min_inlier_share) {
            v.verified = false;
            v.refusal = Refusal::kDepth;
            v.why = fmt::format(
                "{:.0f} % of the range sensor's {} samples on the faces lie within {:.0f} mm of "
                "them, {:.0f} % needed",
                100 * agree.share, agree.samples, 1000 * options_.depth.inlier_distance,
                100 * options_.depth.min_inlier_share);
          }
        }
        // Far less supported than this sequence's verified frames have been: a pose sliding off
        // the object, one edge at a time, keeps passing the absolute tests.
        if (v.verified && typical_agreement_ > 0 &&
            v.agreement < options_.min_share_of_typical * typical_agreement_) {
          v.verified = false;
          v.refusal = Refusal::kTypical;
          v.why = fmt::format(
              "the outline agrees with the image at {:.0f} % of its samples, at "
              "{:.0f} % in the frames before",
              100 * v.agreement, 100 * typical_agreement_);
        }
        if (v.verified) best_outline_ = std::max(best_outline_, v.share);
        // Determined by the data: every visible edge's ends known to `max_position_sigma`.
        if (v.verified) {
          const double sigma = PositionSigma(set->state, at);
          if (sigma > options_.max_position_sigma) {
            v.verified = false;
            v.refusal = Refusal::kUndetermined;
            v.why = fmt::format(
                "the matches leave the pose undetermined: a point of the model "
                "is known to {:.1f} mm, {:.1f} mm at most",
                1000 * sigma, 1000 * options_.max_position_sigma);
            if (!undetermined_ || v.share > undetermined_share_) {
              undetermined_ = set->state;
              undetermined_share_ = v.share;
            }
          }
        }
        // Every part pinned down by the matches, not by the prediction: a lid whose top edge
        // is out of view turns about its hinge with its side edges sliding along themselves.
        if (v.verified) {
          const double spread = Spread(prior.constrained, set->state);
          if (spread > options_.max_spread) {
            v.verified = false;
            v.refusal = Refusal::kSpread;
            v.why = fmt::format(
                "a part is no better known than predicted in some direction "
                "(its standard deviation {:.0f} % of the prediction's)",
                100 * spread);
          }
        }
        // As well supported as this sequence's verified frames are: the search ends.
        const Judgement j{v.verified, v.share,
                          v.verified && typical_share_ > 0 && v.share >= 0.9 * typical_share_};
        // The search keeps the verified set of the highest score; so does this.
        if (v.verified && (!best_judged.verified || v.share > best_judged.share)) {
          best_judged = v;
          best_sigma = PositionSigma(set->state, at);
        }
        last_judged = std::move(v);
        verification_ms += Ms(t, Clock::now());
        return j;
      });
  times.estimation += result.estimation_ms;
  times.verification += verification_ms;
  times.search += Ms(found_at, Clock::now()) - result.estimation_ms - verification_ms;
  out->branches += result.branches;
  if (!result.best) {
    if (!out->verified) out->verification = std::move(last_judged);
    return false;
  }
  out->verification = std::move(best_judged);
  out->position_sigma = best_sigma;
  for (const MatchedLine& line : result.best->lines) {
    for (PredictedEdge& e : out->predicted) {
      if (e.edge != line.edge) continue;
      e.matched = true;
      e.segment_a = line.a;
      e.segment_b = line.b;
    }
  }
  out->matches = static_cast<int>(result.best->lines.size());
  out->residual_sigma = result.best->residual_sigma;
  out->chi2 = result.best->chi2;
  out->fit_dof = std::max(0, result.best->rows - dof_);
  out->model_sigma = result.best->model_sigma;
  out->depth_points = result.best->depth_points;
  out->depth_sigma = result.best->depth_sigma;
  out->estimate = result.best->state;
  out->verified = true;
  return true;
}

TrackedFrame Tracker::TryPlace(const GrayView& image, const Values& place) {
  const auto start = Clock::now();
  const FramePrior prior = Prior(place, 2);
  TrackedFrame attempt;
  attempt.times.prediction += Ms(start, Clock::now());
  TryFrom(image, prior, &attempt);
  return attempt;
}

std::vector<EdgeCandidate> Tracker::Candidates(const GrayView& image,
                                               const std::vector<EdgeModel>& edges) const {
  return options_.evidence == EdgeEvidence::kNormalSearch
             ? NormalSearchCandidates(image, edges, appearance_, options_.evidence_options)
             : SegmentCandidates(image, edges, options_.segments, options_.evidence_options);
}

std::vector<ModelLine> Tracker::ModelLines(const Values& values) const {
  std::vector<ModelLine> out;
  if (graph_.components.size() < 2) return out;
  for (const ProjectedEdge& p : VisibleEdges(graph_, edges_, values, camera_)) {
    out.push_back({graph_.components[edges_[p.edge].component].block, p.a, p.b});
  }
  return out;
}

double Tracker::PriorDistance(const GaussianState& prior, const Values& mean) const {
  const Eigen::VectorXd d = LocalCoordinates(graph_.blocks, prior.mean, mean);
  return d.dot(prior.covariance.ldlt().solve(d));
}

void Tracker::Refine(const GrayView& image, const FramePrior& prior,
                     MatchedSet* set) const {
  const int needed = (dof_ + 1) / 2;
  // A second round from the first's estimate picks up the edges the set's estimate was too far
  // off to find; taken when the first added matches.
  for (int round = 0; round < 2; ++round) {
    const std::vector<EdgeModel> edges =
        PredictEdges(graph_, edges_, set->state, camera_, options_.visibility, model_sigma_,
                     options_.min_edge_pixels);
    std::vector<EdgeCandidate> candidates;
    std::vector<int> chosen;
    if (options_.refine_strongest) {
      candidates = StrongestStepCandidates(image, edges, appearance_, options_.evidence_options,
                                           options_.refine_reach);
      for (size_t c = 0; c < candidates.size(); ++c) chosen.push_back(static_cast<int>(c));
    } else {
      candidates = Candidates(image, edges);
      // Each edge's line by where it lies (the set's estimate with the model's error) times the
      // evidence behind it (hits times their contrast): among lines as near as the model's error
      // allows, the strongest step, as ViSP's moving edges take.
      std::vector<int> best(edges.size(), -1);
      std::vector<double> score(candidates.size(), 0.0);
      for (size_t c = 0; c < candidates.size(); ++c) {
        if (candidates[c].probability < options_.search.min_probability) continue;
        score[c] = std::exp(-0.5 * CandidateDistance(edges[candidates[c].edge], candidates[c])) *
                   candidates[c].hits * candidates[c].strength;
        int& b = best[candidates[c].edge];
        if (b < 0 || score[c] > score[b]) b = static_cast<int>(c);
      }
      for (int b : best) {
        if (b >= 0) chosen.push_back(b);
      }
    }
    // A range sensor's samples on the faces the set's estimate shows, weighed like the edges'
    // matches by their own robust fit: a hand or the background in front of a face, or a face
    // the model places a few millimetres off, is dropped or weighs less.
    const std::vector<DepthMatch> depth =
        depth_ ? MatchDepth(graph_, depth_faces_, set->state.mean, *depth_, options_.depth)
               : std::vector<DepthMatch>{};
    MatchedSet next;
    bool ok = false;
    std::vector<double> weight;
    // The prediction is a measurement too (Lowe's stabilisation). An estimate far outside it
    // says the prediction was wrong (a start far off, a knock), and fused as it was it would pull
    // the estimate toward itself along what the edges leave loose (the depth), with a
    // covariance that claims what the edges do not show: the matches are solved again with the
    // prior widened until the estimate lies within it.
    GaussianState start = prior.free;
    std::vector<double> depth_weight;
    // (within the sensor's noise and a third of the distance that takes a sample for its face's)
    std::vector<double> depth_at_start;
    for (const DepthMatch& m : depth) depth_at_start.push_back(std::abs(m.distance));
    const double depth_start_scale =
        RobustScale(depth_at_start, options_.depth.min_sigma, options_.depth.max_distance / 3);
    double depth_scale = depth_start_scale;
    for (int widen = 0; widen < 3; ++widen) {
      double sigma = model_sigma_;
      weight.assign(chosen.size(), 1.0);
      depth_weight.assign(depth.size(), 1.0);
      depth_scale = depth_start_scale;
      // Iteratively reweighted: each match's weight from its distance to its edge by Tukey's
      // biweight at 4.685 robust standard deviations (ViSP's estimator), a match past it dropped;
      // its noise grown by the inverse of its weight.
      for (int pass = 0; pass < 6; ++pass) {
        std::vector<Factor> factors;
        std::vector<int> used;
        for (size_t i = 0; i < chosen.size(); ++i) {
          if (weight[i] <= 0) continue;
          const EdgeCandidate& k = candidates[chosen[i]];
          // The candidate's noise carries the tracker's model sigma; this pass's replaces it.
          const Eigen::Matrix2d noise = (k.noise + (sigma * sigma - model_sigma_ * model_sigma_) *
                                                       Eigen::Matrix2d::Identity()) /
                                        weight[i];
          factors.push_back(EdgeFactor(camera_, edges[k.edge], k.a, k.b, noise));
          used.push_back(static_cast<int>(i));
        }
        if (static_cast<int>(factors.size()) < needed) {
          ok = false;
          break;
        }
        std::vector<Factor> depth_factors;
        std::vector<int> depth_used;
        // Correlated across the sensor's image: the samples weigh as `effective_points` at most.
        const double share = std::max(1.0, static_cast<double>(depth.size()) /
                                               std::max(1.0, options_.depth.effective_points));
        for (size_t i = 0; i < depth.size(); ++i) {
          if (depth_weight[i] <= 0) continue;
          depth_factors.push_back(DepthFactor(depth_faces_, depth[i],
                                              depth_scale * std::sqrt(share / depth_weight[i])));
          depth_used.push_back(static_cast<int>(i));
        }
        ok = SolveMatches(constraints_, start, factors, graph_.blocks, dof_,
                          options_.search.accept_confidence, &next, depth_factors);
        // Each match's distance from its edge (px, RMS of its two ends), and their robust scale.
        std::vector<double> distance(factors.size());
        Eigen::VectorXd r;
        for (size_t i = 0; i < factors.size(); ++i) {
          EvaluateResidual(*factors[i].residual, graph_.blocks, factors[i].blocks, next.state.mean,
                           &r, nullptr);
          distance[i] = std::sqrt(r.squaredNorm() / 2);
        }
        double change = 0;
        const double scale = TukeyReweight(distance, used, options_.pixel_sigma,
                                           options_.max_model_sigma, &weight, &change);
        next.model_sigma = scale;
        sigma = std::max(sigma, scale);
        if (!depth_factors.empty()) {
          std::vector<double> depth_distance(depth_factors.size());
          for (size_t i = 0; i < depth_factors.size(); ++i) {
            EvaluateResidual(*depth_factors[i].residual, graph_.blocks, depth_factors[i].blocks,
                             next.state.mean, &r, nullptr);
            depth_distance[i] = std::abs(r[0]);
          }
          depth_scale = TukeyReweight(depth_distance, depth_used, options_.depth.min_sigma,
                                      options_.depth.max_distance / 3, &depth_weight, &change);
          next.depth_points = static_cast<int>(std::count_if(
              depth_weight.begin(), depth_weight.end(), [](double w) { return w > 0; }));
          next.depth_sigma = depth_scale;
        }
        if (ok && change < 0.05) break;
      }
      if (!ok || !(options_.prior_confidence < 1)) break;
      const double distance = PriorDistance(start, next.state.mean);
      const double limit = ChiSquareQuantile(options_.prior_confidence, std::max(1, dof_));
      if (distance <= limit) break;
      start.covariance *= distance / limit;
      start.prior_variance *= distance / limit;
    }
    {
      std::vector<int> kept;
      for (size_t i = 0; i < chosen.size(); ++i) {
        if (weight[i] > 0) kept.push_back(chosen[i]);
      }
      chosen = std::move(kept);
    }
    // Kept only when it explains at least as many edges as the set had.
    // (With depth fused the set is kept refined all the same: its estimate is the faces' too.)
    if (!ok || (chosen.size() < set->lines.size() && depth.empty())) return;
    const bool added = chosen.size() > set->lines.size();
    next.set = set->set;
    next.lines.clear();
    for (int c : chosen) {
      next.lines.push_back({edges[candidates[c].edge].edge, candidates[c].a, candidates[c].b});
    }
    *set = std::move(next);
    if (!added) return;
  }
}

}  // namespace cfuse
