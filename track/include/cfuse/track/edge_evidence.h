// Where each predicted edge may be in the image: candidate image lines with Lowe's probability
// that each is the edge (1992, equation 3: p/(p+q), p the prediction's Gaussian density at the
// line's position and angle, q the density of lines like it that clutter would put there).
//
// Two sources, measured against each other in docs/benchmarks.md:
//  - Normal search (the default): every predicted piece sampled every `sample_step` px, a 1D
//    search along the normal at each sample (cfuse/vision/normal_search.h) as far as 3.5 standard
//    deviations of the prediction reach, and the hits grouped into lines by a Hough vote over
//    the lines the prediction allows (offset and slope relative to the predicted piece); each
//    line with enough samples behind it, least-squares fitted to its hits, is a candidate. Only
//    the pixels around the predicted outline are read.
//  - Segments: Lowe's segments detected over the window the edges can reach
//    (cfuse/vision/segments.h), each near an edge at about its angle a candidate.
// A candidate's measurement is the line through its two ends with the covariance of their
// distances across the edge: for a normal-search line, that of the least-squares fit (hit
// noise from the fit's own scatter, at least `min_hit_sigma`), which carries what all its hits
// say about the edge's place and angle in one 2-row factor; plus the edge's noise² (EdgeModel::
// noise) for what the model and the camera get wrong, which more hits do not average away.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/track/edge_prediction.h"
#include "cfuse/vision/normal_search.h"
#include "cfuse/vision/segments.h"

namespace cfuse {

struct EdgeCandidate {
  int edge = -1;          // index into the frame's EdgeModels
  Eigen::Vector2d a, b;   // the measured line over the part of the edge it covers, px
  Eigen::Matrix2d noise;  // covariance of a's and b's distances across the edge, px²
  double probability = 0;
  double clutter = 0;  // q: the density of clutter lines near the edge, per px and radian
  double support = 0;  // the share of the piece's samples on the line (segments: 0.5)
  int polarity = 0;    // +1 / -1: every hit brighter on the normal's / the other side; 0 mixed
  int hits = 0;
  double strength = 0;  // grey levels: the hits' mean |contrast| (segments: their strength)
};

// The sign of the grey-level step across each model edge, by position along it (bins), as the
// last verified frames showed it: hits of the other sign there are not the edge (a texture or
// background line beside it). A face turning in the light can change the sign, so a bin counts
// only once three verified frames in a row agreed on it, and a frame that shows the other sign
// makes it unknown again.
class EdgeAppearance {
 public:
  explicit EdgeAppearance(int edges = 0, int bins = 8);
  // +1 / -1: the image was brighter on the normal's side / the other side at fraction t of the
  // model edge in the last verified frames; 0: not known, or not settled.
  int Polarity(int edge, double t) const;
  // A step at the edge in a verified frame.
  void Record(int edge, double t, float contrast);
  // The recorded steps of a verified frame update what is known (bins without steps keep it).
  void Commit();
  void Forget();

 private:
  struct Bin {
    int sign = 0, streak = 0;  // the last frames' sign, and how many agreed in a row
    int plus = 0, minus = 0;   // recorded, not yet committed
  };
  int bins_;
  std::vector<Bin> table_;
};

struct EvidenceOptions {
  NormalSearchOptions search;
  double sample_step = 5;       // px between samples along a piece
  double end_margin = 3;        // px left out at each end of a piece (the corner's other edge)
  double min_range = 4;         // px searched either side of a sample, at least
  double max_range = 80;        // and at most
  double inlier = 1.5;          // px: a hit within this of a line supports it
  double min_support = 0.25;    // of a piece's samples on a line (and 3 at least)
  int max_lines = 3;            // candidates per piece
  double min_hit_sigma = 0.25;  // px: a hit's error across the edge, at least
  double gate = 18.42;          // chi-square (2 rows) a candidate may lie from the prediction
};

// What a frame's normal search saw: the hits per searched pixel, for what chance alone gives
// a pose (verification.h).
struct SearchStatistics {
  double searched_pixels = 0;
  int hits = 0;
  int samples = 0;
};

// The normal-search candidates of every edge, in edge order.
std::vector<EdgeCandidate> NormalSearchCandidates(const GrayView& image,
                                                  const std::vector<EdgeModel>& edges,
                                                  const EdgeAppearance& appearance,
                                                  const EvidenceOptions& options,
                                                  SearchStatistics* statistics = nullptr);

// One candidate per edge from its samples' strongest steps (ViSP's moving edges): each sample's
// strongest step of the settled polarity within `reach` px, a line fitted through them by
// iteratively reweighted least squares (Tukey's biweight at 4.685 robust standard deviations),
// kept when at least `min_support` of the samples (and 3) lie on it. Where matching is settled
// (a refinement about an estimate), the strongest step near each sample is the edge's, whatever
// texture lies beside it; a line of a few outlying samples does not tilt the fit.
std::vector<EdgeCandidate> StrongestStepCandidates(const GrayView& image,
                                                   const std::vector<EdgeModel>& edges,
                                                   const EdgeAppearance& appearance,
                                                   const EvidenceOptions& options, double reach);

// The segment candidates of every edge (segments detected in the edges' window); `window`
// receives the window searched (for overlays).
std::vector<EdgeCandidate> SegmentCandidates(const GrayView& image,
                                             const std::vector<EdgeModel>& edges,
                                             const SegmentOptions& segments,
                                             const EvidenceOptions& options);

// The squared Mahalanobis distance of candidate c's midpoint offset and angle from edge e as
// predicted now (2 rows), or infinity when c lies beyond the edge's extent.
double CandidateDistance(const EdgeModel& e, const EdgeCandidate& c);

// Lowe's p/(p+q) of candidate c for edge e as predicted now (e tightened by matches taken
// before: the conditional probability), weighted by the candidate's support: 0 outside the gate.
double CandidateProbability(const EdgeModel& e, const EdgeCandidate& c, double gate);

// The length of candidate c along edge e's visible piece.
double Overlap(const EdgeModel& e, const EdgeCandidate& c);

}  // namespace cfuse
