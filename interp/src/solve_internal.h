// The steps of Solve() that live in more than one file: the labelled solve itself (solve.cpp),
// its starts and the answer's neighbours from one image (solve_starts.cpp). Internal to interp:
// not installed.
#pragma once

#include <vector>

#include "cfuse/interp/solve.h"

namespace cfuse::internal {

// Unmeasured single points start where the rigid guess puts them, which is off by however far
// the articulation moved them, and a constraint linearised there can throw the sequential
// pass far along a direction it leaves free. So each is first placed where its constraints to
// known points (measured, or placed before it) hold best, most constrained first.
void PlaceUnmeasured(const ConstraintGraph& g, const std::vector<bool>& measured, Values* x);

// rᵀ R⁻¹ r of a labelled measurement at `values` (R its noise), or infinity when r is not
// finite.
double NormalisedSquare(const ConstraintGraph& graph, const MeasurementSet& set,
                        const ResolvedLabel& r, const Values& values);

// `start` turned about the centroid of the labelled points of `component` (every rigid
// component and point when -1) so that the plane those points lie nearest to has its normal
// mirrored about the line of sight (the camera at the world's origin): the other pose a
// near-planar set of points seen in one image can take, projecting to nearly the same place.
// `fraction` of that turn (1: the mirror image). False when there are fewer than three such
// points.
bool Mirrored(const ConstraintGraph& graph, const std::vector<ResolvedLabel>& labels, int component,
              Values* start, double fraction = 1);

// Whether a solve ended in an answer: converged, no constraint contradicted, every factor valid.
bool Sound(const Solution& s);

// Steps 2-4 for the measurements of `labels`: solution's state, summary, contradictions and
// invalid factors. An image measurement whose point is at or behind the camera at the start is
// not fused, and reported in `invalid`. `pinned`, a functional u of the tangent at the start:
// uᵀ δ is held at 0 (the filter alone, its prior without variance along u), so that the answer
// is the best fit among states with that coordinate given (a profile of the fit).
void SolveLabelled(const ConstraintGraph& graph, const MeasurementSet& set,
                   const SolveOptions& options, const std::vector<ResolvedLabel>& labels,
                   Solution* solution, const Values* start = nullptr,
                   const Eigen::VectorXd* pinned = nullptr);

// The fit's profile along each rigid part's tilt towards its mirror image (Mirrored's turn)
// and away from it: from one image, a near-planar part can slide along a long curved valley
// that the local covariance, right to a few sigmas, does not describe. Each way, the best fit
// with the tilt given is found at 4 sigmas; where its chi-square grew by less than half of the
// Gaussian's 16, the walk goes on (8, 16, 32 sigmas) to the end of the 0.9999 profile interval
// (chi-square up by 15.1). A walk that ends 6 sigmas or more away names the valley
// (Solution::valleys), adds its end to the alternatives unless one lies there, and widens the
// covariance to cover the states it found.
void AddValleyEnds(const ConstraintGraph& graph, const MeasurementSet& set,
                   const SolveOptions& options, const std::vector<ResolvedLabel>& used,
                   Solution* solution);

// From image measurements a solve can end in one of several minima (a near-planar part or the
// whole object mirrored about the line of sight, a point on the far side of its anchors). The
// other closed-form start (the nominal geometry moved as one body) and the mirror images of
// both starts, whole and part by part, are solved too. Then, from the best minimum so far, each
// of its discrete neighbours (Flips) is solved, and the best of them taken while it fits
// better: the lamp's minima differ by one point or one arm at a time, and the answer's mirror
// images alone left 3 of 50 answers on a worse minimum than the truth's, none said. The best fit
// becomes the solution and the other distinct minima that the fit test does not reject its
// alternatives. A best fit with a p-value below SolveOptions::explore_p_value is solved again
// from the whole model posed by PnP at other values of each joint. Last, each rigid part's
// valley of tilt is profiled (AddValleyEnds).
void ExploreStarts(const ConstraintGraph& graph, const MeasurementSet& set,
                   const SolveOptions& options, const std::vector<ResolvedLabel>& used,
                   Solution* solution);

}  // namespace cfuse::internal
