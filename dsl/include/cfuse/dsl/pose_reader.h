// Reading poses in the results format (docs/formats.md): the file's "components" object and,
// if present, its "points"; every other key of a results or truth file (covariances, joints,
// matches, constraints, time) is ignored, so the output of `solve`, `simulate --truth` or
// `fk` can be passed in as it is.
//
//   {"components": {"box": {"position": [0.1, 0, 1.5], "quaternion": [1, 0, 0, 0]}},
//    "points": {"p3": {"xyz": [0.1, 0.2, 1.5]}, "p4": [0.3, 0.1, 1.4]}}
//
// A point is {"xyz": [...]} (results) or a plain [x, y, z] (truth files). A quaternion is
// [w, x, y, z]; one whose norm is off 1 by more than 1e-3 is refused (not silently
// normalised), closer ones are normalised. Errors name the file, line, column and entry.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/kernel/pose_set.h"

namespace cfuse {

PoseSet ReadPoses(const std::string& path);
PoseSet ReadPosesFromString(std::string_view text, const std::string& display_name);

// Joint values for `cfuse fk` (docs/formats.md): a mapping of joint names to numbers (radians,
// metres), or to {"value": number} as in the `joints` of a results file.
std::vector<JointValue> ReadJointValues(const std::string& path);
std::vector<JointValue> ReadJointValuesFromString(std::string_view text,
                                                  const std::string& display_name);

}  // namespace cfuse
