// The results file of `solve` (and later `interpret`), docs/formats.md: every component's pose
// with its covariance, every single point, every joint variable with its sigma, the label each
// measurement was matched to, and how well the constraints hold.
#pragma once

#include <nlohmann/json.hpp>

#include "cfuse/constraints/graph.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/measurement_set.h"
#include "cfuse/kernel/values.h"

namespace cfuse::cli {

nlohmann::json SolutionJson(const ConstraintGraph& graph, const MeasurementSet& set,
                            const Solution& solution, double time_ms);

// Every rigid component's and frame's pose and every single point's position, without
// covariances: {"components": ..., "points": ...}, as in truth files and `fk`'s output.
nlohmann::json PosesJson(const ConstraintGraph& graph, const Values& values);

// A measurement file (docs/formats.md) and the truth file `simulate` writes beside it.
nlohmann::json MeasurementsJson(const MeasurementSet& set);
nlohmann::json TruthJson(const ConstraintGraph& graph, const Values& truth,
                         const std::vector<std::string>& matches);

}  // namespace cfuse::cli
