// Forward kinematics: the pose of every rigid component for given joint values.
//
// Each joint places its child from its parent,
//   world_from_child = world_from_parent * parent_from_joint * Motion(q) * child_from_joint⁻¹,
// from the roots of the joint forest down. A root (a rigid component that is no joint's child)
// sits at the target of a `fixed` pose constraint on it if the model has one (a known base
// pose), else at its nominal pose (a URDF's root link: the identity). Joints not given are at
// their nominal position (the DSL's `position`, 0 for a URDF); a mimic joint follows its leader (q = multiplier * q_leader + offset) and may not be
// given; spherical, planar and floating joints take their nominal motion. Single-point
// components keep their nominal positions; slacks are left at their nominal values.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"

namespace cfuse {

struct JointValue {
  std::string name;
  double value = 0;      // rad or m
  SourceLocation where;  // where it was given, for messages
};

// The joint values every variable joint takes: the given ones, the nominal position for the rest, mimic joints
// from their leaders. A mimic joint's or a locked joint's (MergedJoint) value may be given if it
// is the one it must take. Throws InputError at a value's `where` for a name that is no joint
// of the model, a joint without a variable, a value a mimic or locked joint cannot take, a
// name given twice, or a value that is not finite.
std::map<std::string, double> CompleteJointValues(const ConstraintGraph& graph,
                                                  const std::vector<JointValue>& given);

// The model's configuration at `joint_values` (complete, as above).
Values ForwardKinematics(const ConstraintGraph& graph,
                         const std::map<std::string, double>& joint_values);

// world_from_frame of every rigid component and every frame on one (ComponentFrame), by name,
// in the model's order.
std::vector<std::pair<std::string, Rigid3d>> FramePoses(const ConstraintGraph& graph,
                                                        const Values& values);

// Forward kinematics leaves a closed chain open (a four-bar's loop, a relation that is no
// joint): `values` moved to the configuration nearest it (positions within about 1 % of
// `extent`, rotations 0.03 rad, in a Gaussian prior) where every constraint holds to 1e-10 x
// `extent`, the joints in `held` kept at their values. Inequalities are included only when
// `inequalities` is set (else their slacks are set afterwards, and may be violated). False,
// and `values` unchanged, when no such configuration is found.
bool CloseLoops(const ConstraintGraph& graph, const std::map<std::string, double>& held,
                double extent, bool inequalities, Values* values);

}  // namespace cfuse
