// Writing a constraint graph back as a model file of the DSL (docs/dsl.md): what `cfuse import`
// does with a robot's URDF. Components with their poses (where given), frames, feature points,
// edges and faces; single points; joints with origin, axis, limits, position and mimic.
// Lengths in metres and angles in radians, numbers with 17 significant digits, so that the
// model read back has the same DOF and the same forward kinematics.
//
// Only graphs whose constraints all come from joints (the joint, its limits, its mimic) can be
// written: other constraints keep no source text. Anything else is an InputError at the
// constraint.
#pragma once

#include <string>

#include "cfuse/constraints/graph.h"

namespace cfuse {

std::string WriteModel(const ConstraintGraph& graph);

}  // namespace cfuse
