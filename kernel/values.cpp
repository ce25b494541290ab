#include "kernel/values.h"

#include "kernel/check.h"
#include "kernel/so3.h"

namespace cfuse {

void Retract(const std::vector<Block>& blocks, const Eigen::VectorXd& delta, Values* values) {
  for (const Block& b : blocks) {
    CFUSE_CHECK(b.tangent_offset + TangentDim(b.kind) <= delta.size());
    switch (b.kind) {
      case BlockKind::kPoint:
        values->points.at(b.index) += delta.segment<3>(b.tangent_offset);
        break;
      case BlockKind::kPose: {
        Rigid3d& pose = values->poses.at(b.index);
        const Eigen::Matrix3d R =
            pose.RotationMatrix() * ExpSO3<double>(delta.segment<3>(b.tangent_offset));
        pose.rotation = Eigen::Quaterniond(R).normalized();
        pose.translation += delta.segment<3>(b.tangent_offset + 3);
        break;
      }
      case BlockKind::kSlack:
        values->slacks.at(b.index) += delta[b.tangent_offset];
        break;
    }
  }
}

Eigen::VectorXd LocalCoordinates(const std::vector<Block>& blocks, const Values& from,
                                 const Values& to) {
  int n = 0;
  for (const Block& b : blocks) n = std::max(n, b.tangent_offset + TangentDim(b.kind));
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(n);
  for (const Block& b : blocks) {
    const int o = b.tangent_offset;
    switch (b.kind) {
      case BlockKind::kPoint:
        delta.segment<3>(o) = to.points.at(b.index) - from.points.at(b.index);
        break;
      case BlockKind::kPose: {
        const Rigid3d& a = from.poses.at(b.index);
        const Rigid3d& c = to.poses.at(b.index);
        const Eigen::AngleAxisd relative(a.rotation.conjugate() * c.rotation);
        delta.segment<3>(o) = relative.angle() * relative.axis();
        delta.segment<3>(o + 3) = c.translation - a.translation;
        break;
      }
      case BlockKind::kSlack:
        delta[o] = to.slacks.at(b.index) - from.slacks.at(b.index);
        break;
    }
  }
  return delta;
}

}  // namespace cfuse
