// Poses as read from a file in the results format (docs/formats.md): components' poses and
// single points' positions by name, e.g. a result of `solve` or `fk` passed back in as a guess
// or a starting pose. Plain data; readers (dsl/) fill it, users (interp/, cli/) look names up
// in a model and report unknown ones at the entry.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cfuse/kernel/error.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

struct NamedPose {
  std::string name;
  Rigid3d pose;  // viewer_from_component: x_viewer = R x_component + t
  SourceLocation where;
};

struct NamedPoint {
  std::string name;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  SourceLocation where;
};

struct PoseSet {
  std::string source;  // the file
  std::vector<NamedPose> components;
  std::vector<NamedPoint> points;
};

}  // namespace cfuse
