// The constraint kinds the model languages can name. Adding a kind is one header in this
// folder (a residual templated on the scalar, declaring its Create factory), the factory in
// constraints/src/kinds/<kind>.cpp, its test, and one line in registry.cpp.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/constraints/kinds/joint_frames.h"
#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

// A relation written as a call: parallel(u, v), coplanar(a, b, c, d, ...), rigid(...).
struct RelationKind {
  enum class Argument { kPoint, kVector };
  const char* name;
  ConstraintKind kind;
  Argument argument;  // what each argument is
  int min_args;
  int max_args;  // -1: no upper bound
  const char* usage;
  ConstraintParts (*create)(std::vector<ExprPtr> args, const KindContext& ctx);
};

const RelationKind* FindRelation(std::string_view name);
const std::vector<RelationKind>& AllRelations();
// "parallel, perpendicular, ...": the relations' names, for messages.
std::string RelationNames();

// The residual of a joint of this type, over the slots (parent pose, child pose); not for a
// floating joint, which has none.
std::shared_ptr<const ResidualFunction> MakeJointResidual(JointType type,
                                                          const JointGeometry& geometry);

}  // namespace cfuse
