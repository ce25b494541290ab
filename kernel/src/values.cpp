#include "cfuse/kernel/values.h"

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/so3.h"

namespace cfuse {

void CheckValuesFit(const std::vector<Block>& blocks, const Values& values) {
  for (const Block& b : blocks) {
    CFUSE_CHECK_GE(b.index, 0);
    switch (b.kind) {
      case BlockKind::kPose:
        CFUSE_CHECK_LT(b.index, static_cast<int>(values.poses.size()));
        break;
      case BlockKind::kPoint:
        CFUSE_CHECK_LT(b.index, static_cast<int>(values.points.size()));
        break;
      case BlockKind::kSlack:
        CFUSE_CHECK_LT(b.index, static_cast<int>(values.slacks.size()));
        break;
    }
  }
}

void RetractBlock(const Block& b, const double* delta, Values* values) {
  switch (b.kind) {
    case BlockKind::kPoint:
      values->points.at(b.index) += Eigen::Map<const Eigen::Vector3d>(delta);
      break;
    case BlockKind::kPose: {
      Rigid3d& pose = values->poses.at(b.index);
      const Eigen::Matrix3d R =
          pose.RotationMatrix() * ExpSO3<double>(Eigen::Map<const Eigen::Vector3d>(delta));
      pose.rotation = Eigen::Quaterniond(R).normalized();
      pose.translation += Eigen::Map<const Eigen::Vector3d>(delta + 3);
      break;
    }
    case BlockKind::kSlack:
      values->slacks.at(b.index) += delta[0];
      break;
  }
}

void LocalCoordinatesOfBlock(const Block& b, const Values& from, const Values& to, double* delta) {
  switch (b.kind) {
    case BlockKind::kPoint:
      Eigen::Map<Eigen::Vector3d>{delta} = to.points.at(b.index) - from.points.at(b.index);
      break;
    case BlockKind::kPose: {
      const Rigid3d& a = from.poses.at(b.index);
      const Rigid3d& c = to.poses.at(b.index);
      const Eigen::AngleAxisd relative(a.rotation.conjugate() * c.rotation);
      Eigen::Map<Eigen::Vector3d>{delta} = relative.angle() * relative.axis();
      Eigen::Map<Eigen::Vector3d>{delta + 3} = c.translation - a.translation;
      break;
    }
    case BlockKind::kSlack:
      delta[0] = to.slacks.at(b.index) - from.slacks.at(b.index);
      break;
  }
}

void Retract(const std::vector<Block>& blocks, const Eigen::VectorXd& delta, Values* values) {
  for (const Block& b : blocks) {
    CFUSE_CHECK(b.tangent_offset + TangentDim(b.kind) <= delta.size());
    RetractBlock(b, delta.data() + b.tangent_offset, values);
  }
}

Eigen::VectorXd LocalCoordinates(const std::vector<Block>& blocks, const Values& from,
                                 const Values& to) {
  int n = 0;
  for (const Block& b : blocks) n = std::max(n, b.tangent_offset + TangentDim(b.kind));
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(n);
  for (const Block& b : blocks)
    LocalCoordinatesOfBlock(b, from, to, delta.data() + b.tangent_offset);
  return delta;
}

}  // namespace cfuse
