#include "cfuse/kernel/residual.h"

namespace cfuse {

int ResidualFunction::arity() const {
  int n = 0;
  for (BlockKind k : slot_kinds_) n += TangentDim(k);
  return n;
}

}  // namespace cfuse
