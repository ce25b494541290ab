// A factor: one residual function on its blocks with the covariance of its noise. Measurements
// have a positive-definite noise covariance; constraints have none (zero variance, the
// paper's "perfect measurements", §4): an empty `noise` matrix.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "cfuse/kernel/residual.h"

namespace cfuse {

struct Factor {
  std::shared_ptr<const ResidualFunction> residual;
  std::vector<int> blocks;  // slot -> block id
  Eigen::MatrixXd noise;    // dimension x dimension, or empty for a constraint
  std::string name;         // for reports: the constraint's or the measurement's name

  bool is_constraint() const { return noise.size() == 0; }
};

}  // namespace cfuse
