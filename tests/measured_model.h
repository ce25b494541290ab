// A model's every feature point measured with 1 mm noise, for the batch solvers' tests.
#pragma once

#include <random>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/measurements/point3.h"

namespace cfuse::testing {

// Every feature point of every component measured at `world_from_model` times its nominal
// place, 1 mm noise; then every constraint. `truth` gets the nominal values moved.
inline std::vector<Factor> MeasureEveryPoint(const ConstraintGraph& g,
                                             const Rigid3d& world_from_model, std::mt19937& rng,
                                             Values* truth) {
  std::normal_distribution<double> n(0, 0.001);
  const Eigen::Matrix3d noise = 1e-6 * Eigen::Matrix3d::Identity();
  *truth = g.nominal;
  for (Rigid3d& pose : truth->poses) pose = world_from_model * pose;
  for (Eigen::Vector3d& p : truth->points) p = world_from_model * p;
  std::vector<Factor> factors;
  for (const Component& c : g.components) {
    const Block& b = g.blocks[c.block];
    const auto e = [&] { return Eigen::Vector3d(n(rng), n(rng), n(rng)); };
    if (!c.rigid) {
      factors.push_back({std::make_shared<Point3Residual>(truth->points[b.index] + e()),
                         {c.block},
                         noise,
                         c.name});
      continue;
    }
    for (const FeaturePoint& f : c.points) {
      const Eigen::Vector3d z = truth->poses[b.index] * f.position + e();
      factors.push_back(
          {std::make_shared<Point3Residual>(f.position, z), {c.block}, noise, c.name});
    }
  }
  for (const Constraint& c : g.constraints) factors.push_back({c.residual, c.blocks, {}, c.name});
  return factors;
}

}  // namespace cfuse::testing
