// Helpers of the interpretation tests on articulated models among clutter.
#pragma once

#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"

namespace cfuse::testing {

// A configuration with its joints drawn inside their limits, measured in 3D among as many
// clutter points as real ones.
inline Simulation ArticulatedAmongClutter(const ConstraintGraph& g, unsigned seed) {
  SimulateOptions so;
  so.seed = seed;
  so.sample_joints = true;
  so.clutter = 1;
  return Simulate(g, so);
}

// Whether the answer or one of its alternatives has every component's pose within 1 cm at
// two points off its origin, 5 and 12 cm away on different axes (a turn about either shows).
inline bool OffersTruth(const Simulation& sim, const Solution& solution) {
  auto is_truth = [&](const Values& v) {
    for (size_t i = 0; i < v.poses.size(); ++i) {
      for (const Eigen::Vector3d& x : {Eigen::Vector3d(0.12, 0, 0), Eigen::Vector3d(0, 0.05, 0)}) {
        if ((v.poses[i] * x - sim.truth.poses[i] * x).norm() > 0.01) return false;
      }
    }
    return true;
  };
  bool found = is_truth(solution.state.mean);
  for (const Solution::Alternative& a : solution.alternatives) found = found || is_truth(a.mean);
  return found;
}

}  // namespace cfuse::testing
