// What `solve`, `interpret` and `fk` compute and judge, apart from reading and writing files:
// shared by the commands and the Python module, so that both give the same result and the same
// verdict for the same input.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/constraints/graph.h"
#include "cfuse/interp/interpretation.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/measurement_set.h"
#include "cfuse/kernel/pose_set.h"

namespace cfuse::cli {

// A verdict: the exit status a command gives (0 right as far as the data tell, 1 no acceptable
// answer) and the lines it says why, each a sentence without the program's name; warnings start
// with "warning: " and do not change the status.
struct Verdict {
  int status = 0;
  std::vector<std::string> lines;
};

// `method`: "fusion", "parametric" or "components" (SolveCommandOptions); anything else is an
// InputError at "method". The result is the solve's JSON (docs/formats.md) with its verdict.
struct SolveAnswer {
  nlohmann::json result;
  Verdict verdict;
};
SolveAnswer SolveAndJudge(const ConstraintGraph& graph, const MeasurementSet& set,
                          const std::string& method, const PoseSet* guess);

struct InterpretAnswer {
  Interpretation interpretation;
  nlohmann::json result;  // null when no measurement matched any model point
  Verdict verdict;
};
InterpretAnswer InterpretAndJudge(const ConstraintGraph& graph, const MeasurementSet& set,
                                  const InterpretOptions& options);

// `fk`'s result: every pose, with closed chains closed about the given joints (the others moved
// until every equality holds), and the joints' values; the verdict warns of values beyond their
// limits, and fails when the constraints cannot all hold.
struct FkAnswer {
  nlohmann::json result;
  Verdict verdict;
};
FkAnswer ForwardKinematicsAndJudge(const ConstraintGraph& graph,
                                   const std::vector<JointValue>& given);

}  // namespace cfuse::cli
