#include "track/tracker.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "constraints/dof.h"
#include "constraints/evaluate.h"
#include "kernel/chi_square.h"
#include "kernel/evaluate.h"
#include "kernel/measurements/image_segment.h"
#include "vision/segment_index.h"

namespace cfuse::track {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

// An edge as this frame predicts it, with what matching needs.
struct EdgeModel {
  int edge = -1;             // index into the model's edges
  int block = -1;            // its component's pose block
  Eigen::Vector3d A, B;      // its model points, component coordinates
  Eigen::Vector2d a, b;      // its visible part, pixels
  Eigen::Vector2d mid, dir;  // midpoint, unit direction
  double length = 0, orientation = 0;
  double sigma_a = 0, sigma_b = 0;  // across the edge at each end (prediction only)
  double sigma_x = 0, sigma_y = 0;  // midpoint across (px) and angle (rad), noise included
  double noise = 1;                 // px: a matched segment end's error across the edge
};

// The image-segment factor of edge `e` measured by segment (p, q).
Factor SegmentFactor(const Camera& camera, const EdgeModel& e, const Eigen::Vector2d& p,
                     const Eigen::Vector2d& q) {
  return {std::make_shared<ImageSegmentResidual>(camera, e.A, e.B, p, q),
          {e.block},
          e.noise * e.noise * Eigen::Matrix2d::Identity(),
          "edge"};
}

// Fills the edge's variances from `state` (Lowe's S = A P Aᵀ, its diagonal and the one
// covariance the midpoint and the angle need) and the pixel noise. False when the prediction is
// not finite (an end behind the camera).
bool PredictVariance(const Camera& camera, const GaussianState& state, EdgeModel* e) {
  const double pixel_sigma = e->noise;
  const Prediction p = Predict(SegmentFactor(camera, *e, e->a, e->b), state);
  if (!p.valid || !p.covariance.allFinite()) return false;
  const Eigen::Matrix2d& S = p.covariance;
  e->sigma_a = std::sqrt(std::max(0.0, S(0, 0)));
  e->sigma_b = std::sqrt(std::max(0.0, S(1, 1)));
  const double mid = 0.25 * (S(0, 0) + S(1, 1) + 2 * S(0, 1));
  const double turn = (S(0, 0) + S(1, 1) - 2 * S(0, 1)) / (e->length * e->length);
  e->sigma_x = std::sqrt(std::max(0.0, mid) + pixel_sigma * pixel_sigma);
  e->sigma_y =
      std::sqrt(std::max(0.0, turn) + 2 * pixel_sigma * pixel_sigma / (e->length * e->length));
  return true;
}

// Lowe's probability that segment (p, q) is edge e's image, or 0 outside the gate: p/(p+q)
// with p the Gaussian density of the midpoint's perpendicular distance and the angle, and q the
// background density `background` times the interval (m - s) the midpoint may fall in.
double MatchProbability(const EdgeModel& e, const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                        double background, double gate) {
  const Eigen::Vector2d d = q - p;
  const double s = d.norm();
  if (s == 0) return 0;
  const Eigen::Vector2d normal(-e.dir.y(), e.dir.x());
  const Eigen::Vector2d m = 0.5 * (p + q) - e.mid;
  const double x = normal.dot(m);
  double angle = std::atan2(d.y(), d.x()) - e.orientation;
  angle = std::remainder(angle, M_PI);  // segments have no arrow
  const double z = (x * x) / (e.sigma_x * e.sigma_x) + (angle * angle) / (e.sigma_y * e.sigma_y);
  if (!(z <= gate)) return 0;
  // The edge extended by its uncertainty: the segment's midpoint within (m - s)/2 of its centre.
  const double extended = e.length + 6 * e.sigma_x;
  if (s > extended) return 0;
  if (std::abs(e.dir.dot(m)) > 0.5 * (extended - s)) return 0;
  const double density = std::exp(-0.5 * z) / (2 * M_PI * e.sigma_x * e.sigma_y);
  const double clutter = background * std::max(extended - s, 1.0);
  return density / (density + clutter);
}

// How much of the visible model a match set explains: the matched share of the visible edges'
// length, and the least such share of any component in view.
struct Coverage {
  double share = 0, least = 0;
};

// The length of segment (p, q) along edge e, within the edge's visible part.
double Overlap(const EdgeModel& e, const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
  double t0 = e.dir.dot(p - e.a), t1 = e.dir.dot(q - e.a);
  if (t0 > t1) std::swap(t0, t1);
  return std::max(0.0, std::min(t1, e.length) - std::max(t0, 0.0));
}

}  // namespace

Tracker::Tracker(const ConstraintGraph& graph, const Camera& camera, const Values& initial,
                 TrackerOptions options)
    : graph_(graph), camera_(camera), options_(std::move(options)) {
  if (camera_.width <= 0 || camera_.height <= 0) {
    throw std::invalid_argument("the camera has no image size (width and height)");
  }
  edges_ = vision::ModelEdges(graph_);
  for (const Constraint& c : graph_.constraints)
    constraints_.push_back({c.residual, c.blocks, {}, c.name});
  const DofReport dof = AnalyzeDof(graph_, graph_.nominal);
  if (dof.computed) dof_ = dof.dof;
  // The start's slacks from its poses: a limit's slack left at the nominal geometry's value
  // would pull the joint there as soon as the limit is fused.
  Values start = initial;
  MatchSlacks(graph_, &start);
  history_ = {{0, start}};
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

TrackedFrame Tracker::Track(const vision::GrayView& image) {
  if (image.width != camera_.width || image.height != camera_.height) {
    throw std::invalid_argument(
        "the image is " + std::to_string(image.width) + " x " + std::to_string(image.height) +
        ", the camera's " + std::to_string(camera_.width) + " x " + std::to_string(camera_.height));
  }
  const Values predicted = Predicted();
  TrackedFrame out;
  // The search range grows with the frames since the last verified one (the prediction is that
  // much older), then doubles on failure.
  const int lost = std::max(0, frame_ - history_.back().first - 1);
  const double base = std::min<double>(1 + lost, options_.max_lost_growth);
  for (int d = 0; d <= options_.max_doublings; ++d) {
    if (TryRange(image, base, d, predicted, &out)) break;
  }
  if (out.verified) {
    // (the initial configuration is frame 0's guess: frame 0's estimate replaces it)
    if (history_.back().first == frame_) history_.pop_back();
    // A frame found only by doubling the range broke with the motion so far (a knock, a
    // jerk): the step to it is no velocity to carry on. The next frame predicts no motion.
    if (out.doublings > 0) history_.clear();
    history_.push_back({frame_, out.estimate.mean});
    if (history_.size() > 2) history_.erase(history_.begin());
  }
  ++frame_;
  return out;
}

bool Tracker::TryRange(const vision::GrayView& image, double base, int doublings,
                       const Values& predicted, TrackedFrame* out) {
  FrameTimes& times = out->times;
  auto start = Clock::now();
  const double scale = base * std::ldexp(1.0, doublings);
  out->doublings = doublings;
  // 1. The prior about the prediction, on the model's own configurations.
  GaussianState prior = MakePrior(
      graph_.blocks, predicted,
      PriorScale{options_.translation_range * scale, options_.rotation_range * scale, 1e4});
  // A part on a joint turns about it on top of its parent's motion: a wider rotation range.
  for (const Joint& j : graph_.joints) {
    const Block& b = graph_.blocks[graph_.components[j.child].block];
    const double sigma = options_.joint_rotation_range * scale;
    prior.prior_variance.segment<3>(b.tangent_offset).setConstant(sigma * sigma);
    prior.covariance.diagonal().segment<3>(b.tangent_offset).setConstant(sigma * sigma);
  }
  GaussianState constrained = prior;
  for (const Factor& c : constraints_) Fuse(c, &constrained);
  out->estimate = constrained;
  out->predicted.clear();
  out->verified = false;
  out->matches = 0;
  out->matched_share = 0;

  // 2. The visible edges and their variances.
  std::vector<EdgeModel> edges;
  const std::vector<vision::ProjectedEdge> visible =
      vision::VisibleEdges(graph_, edges_, constrained.mean, camera_, options_.visibility);
  for (const vision::ProjectedEdge& p : visible) {
    EdgeModel e;
    e.edge = p.edge;
    const vision::ModelEdge& m = edges_[p.edge];
    const Component& c = graph_.components[m.component];
    e.block = c.block;
    e.A = c.points[m.a].position;
    e.B = c.points[m.b].position;
    e.a = p.a;
    e.b = p.b;
    e.length = (p.b - p.a).norm();
    if (e.length < options_.min_edge_pixels) continue;
    e.dir = (p.b - p.a) / e.length;
    e.mid = 0.5 * (p.a + p.b);
    e.orientation = std::atan2(e.dir.y(), e.dir.x());
    e.noise = options_.pixel_sigma;
    if (!PredictVariance(camera_, constrained, &e)) continue;
    edges.push_back(e);
    PredictedEdge shown;
    shown.edge = e.edge;
    shown.a = e.a;
    shown.b = e.b;
    shown.sigma_a = e.sigma_a;
    shown.sigma_b = e.sigma_b;
    out->predicted.push_back(shown);
  }
  auto predicted_at = Clock::now();
  times.prediction += Ms(start, predicted_at);
  const int needed = (dof_ + 1) / 2;
  if (static_cast<int>(edges.size()) < needed) return false;

  // Segments where the edges can be seen: their box, widened by 3 sigma and a margin.
  vision::SegmentOptions so = options_.segments;
  int x0 = 0, y0 = 0, x1 = camera_.width, y1 = camera_.height;
  if (options_.region_of_interest) {
    Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
    for (const EdgeModel& e : edges) {
      const double margin = 3 * std::max(e.sigma_a, e.sigma_b) + 3 * options_.pixel_sigma + 8;
      lo = lo.cwiseMin(e.a.cwiseMin(e.b) - Eigen::Vector2d::Constant(margin));
      hi = hi.cwiseMax(e.a.cwiseMax(e.b) + Eigen::Vector2d::Constant(margin));
    }
    x0 = std::clamp(static_cast<int>(std::floor(lo.x())), 0, camera_.width - 1);
    y0 = std::clamp(static_cast<int>(std::floor(lo.y())), 0, camera_.height - 1);
    x1 = std::clamp(static_cast<int>(std::ceil(hi.x())) + 1, x0 + 1, camera_.width);
    y1 = std::clamp(static_cast<int>(std::ceil(hi.y())) + 1, y0 + 1, camera_.height);
    so.roi = vision::PixelRect{x0, y0, x1 - x0, y1 - y0};
  }
  const std::vector<vision::ImageSegment> segments = vision::DetectSegments(image, so);
  const vision::SegmentIndex index(segments, camera_.width, camera_.height);
  auto detected = Clock::now();
  times.segments += Ms(predicted_at, detected);

  // 3. Candidates, with Lowe's probabilities against the window's background.
  const double background =
      static_cast<double>(segments.size()) / (M_PI * static_cast<double>(x1 - x0) * (y1 - y0));
  const double gate = ChiSquareQuantile(0.9999, 2);
  std::vector<Candidate> candidates;
  std::vector<int> found;
  std::vector<bool> edge_has(edges.size(), false);
  for (size_t i = 0; i < edges.size(); ++i) {
    const EdgeModel& e = edges[i];
    index.Query(e.mid.cast<float>(), static_cast<float>(0.5 * e.length + 3 * e.sigma_x + 2),
                static_cast<float>(e.orientation),
                static_cast<float>(std::min(M_PI / 2, 3 * e.sigma_y + 0.02)), &found);
    for (int s : found) {
      const double probability = MatchProbability(e, segments[s].a.cast<double>(),
                                                  segments[s].b.cast<double>(), background, gate);
      if (probability < options_.min_probability) continue;
      candidates.push_back({static_cast<int>(i), s, probability});
      edge_has[i] = true;
    }
  }
  if (std::count(edge_has.begin(), edge_has.end(), true) < needed) {
    times.search += Ms(detected, Clock::now());
    return false;
  }

  // 4. Best-first search over match sets.
  SequenceOptions sequence;
  sequence.gauss_newton_from_start = true;
  sequence.max_passes = 6;
  sequence.constraint_tolerance = 1e-9;
  auto solve = [&](const std::vector<int>& set, GaussianState* state, double* sigma) {
    const auto t = Clock::now();
    std::vector<Factor> factors = constraints_;
    for (int c : set) {
      const vision::ImageSegment& s = segments[candidates[c].segment];
      factors.push_back(SegmentFactor(camera_, edges[candidates[c].edge], s.a.cast<double>(),
                                      s.b.cast<double>()));
    }
    *state = prior;
    const SequenceSummary summary = FuseSequence(factors, state, sequence);
    // Lowe's residual test: the matches' whitened residuals against a chi-square with the
    // rows the fit leaves free.
    double sum = 0, chi2 = 0;
    Eigen::VectorXd r;
    for (size_t k = constraints_.size(); k < factors.size(); ++k) {
      EvaluateResidual(*factors[k].residual, graph_.blocks, factors[k].blocks, state->mean, &r,
                       nullptr);
      sum += r.squaredNorm();
      chi2 += r.squaredNorm() / factors[k].noise(0, 0);
    }
    const int rows = 2 * static_cast<int>(set.size());
    *sigma = std::sqrt(sum / std::max(1, rows));
    const bool ok = summary.converged && std::isfinite(chi2) &&
                    chi2 <= ChiSquareQuantile(options_.accept_confidence, std::max(1, rows - dof_));
    times.estimation += Ms(t, Clock::now());
    return ok;
  };
  std::vector<double> probability(candidates.size());
  for (size_t c = 0; c < candidates.size(); ++c) probability[c] = candidates[c].probability;
  std::vector<std::vector<int>> rejected;  // sorted candidate indices
  auto completes_rejected = [&](const std::vector<int>& set, int c) {
    std::vector<int> with = set;
    with.push_back(c);
    std::sort(with.begin(), with.end());
    return std::any_of(rejected.begin(), rejected.end(), [&](const std::vector<int>& r) {
      return std::includes(with.begin(), with.end(), r.begin(), r.end());
    });
  };
  // The edges as `state` predicts them: each visible part moved onto the line through its
  // projected model points, with the variances of that state.
  auto reproject = [&](const GaussianState& state, std::vector<EdgeModel>* moved) {
    for (EdgeModel& e : *moved) {
      const Rigid3d& pose = state.mean.poses[graph_.blocks[e.block].index];
      const Eigen::Vector2d a = camera_.Project<double>(pose * e.A);
      const Eigen::Vector2d b = camera_.Project<double>(pose * e.B);
      if (!a.allFinite() || !b.allFinite() || (b - a).norm() == 0) continue;
      const Eigen::Vector2d dir = (b - a).normalized();
      const Eigen::Vector2d from = a + dir * dir.dot(e.a - a);
      const Eigen::Vector2d to = a + dir * dir.dot(e.b - a);
      if ((to - from).norm() == 0) continue;
      e.a = from;
      e.b = to;
      e.length = (e.b - e.a).norm();
      e.dir = (e.b - e.a) / e.length;
      e.mid = 0.5 * (e.a + e.b);
      e.orientation = std::atan2(e.dir.y(), e.dir.x());
      PredictVariance(camera_, state, &e);
    }
  };

  // An accepted set extended, round by round, with every match the tightened prediction
  // supports (probability above one half), each round solved again; the set that explains the
  // most and still passes, and the share of the visible edges' length it covers.
  auto extend = [&](std::vector<int> set, GaussianState* state, double* sigma) {
    for (int round = 0; round < 3; ++round) {
      std::vector<EdgeModel> tight = edges;
      reproject(*state, &tight);
      std::vector<bool> edge_used(edges.size(), false), segment_used(segments.size(), false);
      for (int c : set) edge_used[candidates[c].edge] = segment_used[candidates[c].segment] = true;
      std::vector<std::pair<double, int>> supported;
      for (size_t c = 0; c < candidates.size(); ++c) {
        if (edge_used[candidates[c].edge] || segment_used[candidates[c].segment]) continue;
        const vision::ImageSegment& s = segments[candidates[c].segment];
        const double p = MatchProbability(tight[candidates[c].edge], s.a.cast<double>(),
                                          s.b.cast<double>(), background, gate);
        if (p >= 0.5) supported.push_back({p, static_cast<int>(c)});
      }
      std::sort(supported.begin(), supported.end(), std::greater<>());
      std::vector<int> more = set;
      for (const auto& [p, c] : supported) {
        if (edge_used[candidates[c].edge] || segment_used[candidates[c].segment]) continue;
        more.push_back(c);
        edge_used[candidates[c].edge] = segment_used[candidates[c].segment] = true;
      }
      if (more.size() == set.size()) break;
      GaussianState next;
      double next_sigma = 0;
      if (!solve(more, &next, &next_sigma)) break;
      set = std::move(more);
      *state = std::move(next);
      *sigma = next_sigma;
    }
    // The share of the visible edges' length matched, over the model and per component.
    std::vector<double> total(graph_.blocks.size(), 0.0), matched(graph_.blocks.size(), 0.0);
    for (const EdgeModel& e : edges) total[e.block] += e.length;
    for (int c : set) {
      const EdgeModel& e = edges[candidates[c].edge];
      const vision::ImageSegment& s = segments[candidates[c].segment];
      matched[e.block] += Overlap(e, s.a.cast<double>(), s.b.cast<double>());
    }
    Coverage coverage;
    double all = 0, all_matched = 0;
    coverage.least = 1;
    for (size_t b = 0; b < total.size(); ++b) {
      all += total[b];
      all_matched += matched[b];
      if (total[b] >= options_.min_component_pixels) {
        coverage.least = std::min(coverage.least, matched[b] / total[b]);
      }
    }
    coverage.share = all > 0 ? all_matched / all : 0.0;
    return std::make_pair(set, coverage);
  };

  // How far the matches pin every component down: its posterior standard deviation over the
  // prediction's (constraints fused), in its worst direction (the largest generalised
  // eigenvalue of the two covariances; 1: the matches taught nothing about it, as for a lid
  // whose only matched edge is its hinge).
  auto spread = [&](const GaussianState& state) {
    double worst = 0;
    for (const Component& c : graph_.components) {
      if (!c.rigid) continue;
      const int o = graph_.blocks[c.block].tangent_offset;
      const Eigen::Matrix<double, 6, 6> before = constrained.covariance.block<6, 6>(o, o);
      const Eigen::Matrix<double, 6, 6> after = state.covariance.block<6, 6>(o, o);
      const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> ratio(
          after, before, Eigen::EigenvaluesOnly);
      if (ratio.info() != Eigen::Success) return 1.0;
      worst = std::max(worst, std::sqrt(std::max(0.0, ratio.eigenvalues().maxCoeff())));
    }
    return worst;
  };

  // The verified set that explains the most, of those tried.
  struct Verified {
    std::vector<int> set;
    GaussianState state;
    double sigma = 0, share = 0, least = 0, spread = 0;
  };
  std::optional<Verified> best;
  const double estimation_before = times.estimation, verification_before = times.verification;
  for (int branch = 0; branch < options_.max_branches; ++branch) {
    // The set, best first: each match taken tightens the prediction for the next (it is fused
    // into a copy of the prior and the edges re-predicted), so that the next is the most
    // probable given those before it (Hel-Or & Werman's interpretation tree, one path down
    // it). The first pick, and the order at the prediction's own range, are Lowe's.
    std::vector<int> set;
    std::vector<bool> edge_used(edges.size(), false), segment_used(segments.size(), false);
    GaussianState given = constrained;
    std::vector<double> conditional = probability;
    double product = 1;
    for (;;) {
      int best = -1;
      for (size_t c = 0; c < candidates.size(); ++c) {
        const Candidate& k = candidates[c];
        if (edge_used[k.edge] || segment_used[k.segment]) continue;
        if (best >= 0 && conditional[c] <= conditional[best]) continue;
        if (completes_rejected(set, static_cast<int>(c))) continue;
        best = static_cast<int>(c);
      }
      if (best < 0 || conditional[best] < options_.min_probability) break;
      if (static_cast<int>(set.size()) >= needed && product * conditional[best] < 0.9) break;
      const Candidate& k = candidates[best];
      set.push_back(best);
      edge_used[k.edge] = segment_used[k.segment] = true;
      product *= conditional[best];
      if (!options_.conditional_sets) continue;
      const vision::ImageSegment& s = segments[k.segment];
      Fuse(SegmentFactor(camera_, edges[k.edge], s.a.cast<double>(), s.b.cast<double>()), &given);
      std::vector<EdgeModel> now = edges;
      reproject(given, &now);
      for (size_t c = 0; c < candidates.size(); ++c) {
        if (edge_used[candidates[c].edge] || segment_used[candidates[c].segment]) continue;
        const vision::ImageSegment& t = segments[candidates[c].segment];
        // (times what rejected sets took off it)
        conditional[c] = MatchProbability(now[candidates[c].edge], t.a.cast<double>(),
                                          t.b.cast<double>(), background, gate) *
                         probability[c] / candidates[c].probability;
      }
    }
    if (static_cast<int>(set.size()) < needed) break;
    ++out->branches;
    GaussianState trial;
    double trial_sigma = 0;
    if (solve(set, &trial, &trial_sigma)) {
      // 5. Extended and verified: a set that fits but explains too little of the model is no
      // better evidence than one that does not fit.
      const auto verify_start = Clock::now();
      const double before = times.estimation;
      auto [extended, coverage] = extend(set, &trial, &trial_sigma);
      const double trial_spread = spread(trial);
      times.verification += Ms(verify_start, Clock::now()) - (times.estimation - before);
      out->spread = trial_spread;
      out->component_share = coverage.least;
      // Verified: the set covers enough of the visible edges, and of each part in view, pins
      // every part down, and has matches to spare beyond the model's degrees of freedom (a few
      // matches fit a wrong pose as well as the right one).
      const bool verified = coverage.share >= options_.verify_share &&
                            coverage.least >= options_.verify_component_share &&
                            trial_spread <= options_.max_spread &&
                            static_cast<int>(extended.size()) >= needed + options_.spare_matches;
      if (verified && (!best || coverage.share > best->share)) {
        best = Verified{std::move(extended), std::move(trial), trial_sigma,
                        coverage.share,      coverage.least,   trial_spread};
      }
      // A set that explains most of the model ends the search; one that explains little may
      // be a wrong pose that happens to fit a few edges: the other branches are tried too,
      // and the best verified set wins.
      if (verified && coverage.share >= options_.confident_share) break;
    }
    for (int c : set) probability[c] *= 1 - 1.0 / static_cast<double>(set.size());
    std::sort(set.begin(), set.end());
    rejected.push_back(set);
  }
  times.search += Ms(detected, Clock::now()) - (times.estimation - estimation_before) -
                  (times.verification - verification_before);
  if (!best) return false;
  for (int c : best->set) {
    PredictedEdge& e = out->predicted[candidates[c].edge];
    e.matched = true;
    e.segment_a = segments[candidates[c].segment].a.cast<double>();
    e.segment_b = segments[candidates[c].segment].b.cast<double>();
  }
  out->matched_share = best->share;
  out->component_share = best->least;
  out->spread = best->spread;
  out->matches = static_cast<int>(best->set.size());
  out->residual_sigma = best->sigma;
  out->estimate = std::move(best->state);
  out->verified = true;
  return true;
}

}  // namespace cfuse::track
