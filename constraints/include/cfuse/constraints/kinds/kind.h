// What every constraint kind's factory shares in its signature: the context it is built in,
// what it returns, the bound arguments its residual keeps, and how it reports a constraint that
// cannot be built (degenerate at the nominal geometry, wrong argument types). KindError carries
// only the message; the caller (DSL, importer) knows where in the user's file the constraint
// was written and wraps it into an InputError. The factories' shared steps (binding, nominal
// values, refusals, base points) are internal: constraints/src/kinds/kind_support.h.
#pragma once

#include <memory>
#include <stdexcept>
#include <vector>

#include "cfuse/constraints/expr.h"
#include "cfuse/kernel/residual.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

class KindError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct KindContext {
  const std::vector<Block>* blocks = nullptr;  // the graph's blocks so far
  const Values* nominal = nullptr;             // their nominal values
  int slack_block = -1;  // the block reserved for this constraint's slack, if it needs one
};

struct ConstraintParts {
  std::shared_ptr<const ResidualFunction> residual;
  std::vector<int> blocks;  // slot -> block id
  int slack_block = -1;
};

// Expressions bound to local slots, with their blocks and the blocks' kinds (what a relation's
// residual keeps).
struct BoundArgs {
  std::vector<ExprPtr> exprs;
  std::vector<int> blocks;
  std::vector<BlockKind> kinds;
};

}  // namespace cfuse
