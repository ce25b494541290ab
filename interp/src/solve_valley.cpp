// The ends of a long, curved valley of the fit from one image. A near-planar part seen by one
// camera can tilt towards its mirror image, moving in depth and sideways as it turns, with
// little change in its image: the local covariance is right to a few sigmas along each of its
// axes, yet the fit stays acceptable far beyond, along a curve that no straight line from the
// answer follows (a Stewart platform's top plate: the answer 18 degrees from the truth, whose
// chi-square is only 16 higher, and no minimum there). The fit's profile follows that curve: the
// best fit with the part's tilt given, everything else free. Where it finds the fit inside its
// interval far beyond the covariance's, the covariance is widened to cover what it found and the
// valley is named (Solution::valleys): the truth may lie anywhere along it.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "cfuse/kernel/chi_square.h"
#include "solve_internal.h"

namespace cfuse::internal {

void AddValleyEnds(const ConstraintGraph& graph, const MeasurementSet& set,
                   const SolveOptions& options, const std::vector<ResolvedLabel>& used,
                   Solution* solution) {
  if (!options.profile_valleys || !Sound(*solution) || !solution->fits) return;
  const Eigen::MatrixXd& P = solution->state.covariance;
  // A large model's covariance holds only the blocks results report (NaN between others,
  // SolveOptions::full_covariance_below), and its profiles would run the dense filter: a
  // valley there is not looked for.
  if (!P.allFinite()) return;
  const Values& answer = solution->state.mean;
  // The profile interval at 0.9999, one coordinate: the level the benchmarks judge answers at.
  static const double gate = ChiSquareQuantile(0.9999, 1);
  const double chi2 = solution->analysis.fit.chi2;
  const auto inside = [&](const Solution& at) {
    return Sound(at) && at.analysis.fit.p_value >= options.min_p_value &&
           at.analysis.fit.chi2 - chi2 <= gate;
  };
  std::vector<Eigen::VectorXd> spread;  // the profile's points inside, where it is not Gaussian
  constexpr int kBisections = 3;
  constexpr double kFirst = 4, kLast = 32, kReported = 6;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (!graph.components[c].rigid) continue;
    const Block& block = graph.blocks[graph.components[c].block];
    const int o = block.tangent_offset;
    Values mirror = answer;
    if (!Mirrored(graph, used, static_cast<int>(c), &mirror)) continue;
    // The tilt towards the mirror image, in the pose's chart (R <- R Exp(dθ)).
    const Rigid3d& pose = answer.poses[block.index];
    const Eigen::AngleAxisd turn(pose.rotation.conjugate() * mirror.poses[block.index].rotation);
    if (!(turn.angle() > 0)) continue;
    const double sigma = std::sqrt(turn.axis().dot(P.block<3, 3>(o, o) * turn.axis()));
    if (!(sigma > 0)) continue;
    Eigen::VectorXd u = Eigen::VectorXd::Zero(P.rows());
    u.segment<3>(o) = turn.axis();
    Solution::Valley valley{graph.components[c].name, 0, 0};
    for (const double sign : {1.0, -1.0}) {
      // The best fit with the part turned by `k` sigmas of tilt, started there with the rest of
      // the answer as it is; its tilt held by the prior (SolveLabelled's `pinned`).
      const auto at = [&](double k) {
        Values start = answer;
        Mirrored(graph, used, static_cast<int>(c), &start, sign * k * sigma / turn.angle());
        Solution here;
        here.extent = solution->extent;
        SolveLabelled(graph, set, options, used, &here, &start, &u);
        return here;
      };
      // Along a Gaussian valley the chi-square grows by k² at k sigmas, past the gate at 4: one
      // solve. Where it grew by less than half that, the walk goes on, doubling.
      Solution last;
      std::vector<Eigen::VectorXd> found;
      double k_in = 0, k_out = 0;
      const auto keep = [&](Solution here, double k) {
        found.push_back(LocalCoordinates(graph.blocks, answer, here.state.mean));
        last = std::move(here);
        k_in = k;
      };
      for (double k = kFirst; k <= kLast; k *= 2) {
        Solution here = at(k);
        if (!inside(here)) {
          k_out = k;
          break;
        }
        keep(std::move(here), k);
        if (last.analysis.fit.chi2 - chi2 >= k * k / 2) break;
      }
      if (k_in == 0) continue;
      for (int b = 0; b < kBisections && k_out > 0; ++b) {
        const double k = (k_in + k_out) / 2;
        Solution here = at(k);
        if (inside(here)) {
          keep(std::move(here), k);
        } else {
          k_out = k;
        }
      }
      if (k_in < kReported) continue;
      spread.insert(spread.end(), found.begin(), found.end());
      (sign > 0 ? valley.towards_mirror : valley.away) = k_in * sigma;
      if (!Distinct(graph, last.state.mean, solution->state, solution->extent)) continue;
      const bool known =
          std::any_of(solution->alternatives.begin(), solution->alternatives.end(),
                      [&](const Solution::Alternative& a) {
                        return !Distinct(graph, a.mean, last.state, solution->extent);
                      });
      if (!known) solution->alternatives.push_back({last.state.mean, last.analysis.fit});
    }
    if (valley.towards_mirror > 0 || valley.away > 0) solution->valleys.push_back(valley);
  }
  std::stable_sort(solution->alternatives.begin(), solution->alternatives.end(),
                   [](const Solution::Alternative& a, const Solution::Alternative& b) {
                     return a.fit.chi2 < b.fit.chi2;
                   });
  // Each point d found inside the interval ends inside the covariance's own interval at the
  // same level: with P' ⪰ d dᵀ / gate, dᵀ P'⁺ d <= gate. (Conservative where P covers part of d
  // already: at most the sum of the two.)
  for (const Eigen::VectorXd& d : spread) {
    solution->state.covariance.noalias() += d * d.transpose() / gate;
  }
}

}  // namespace cfuse::internal
