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

}  // namespace cfuse
