#include "cfuse/constraints/kinds/registry.h"

#include "cfuse/constraints/kinds/collinear.h"
#include "cfuse/constraints/kinds/coplanar.h"
#include "cfuse/constraints/kinds/fixed_joint.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/constraints/kinds/parallel.h"
#include "cfuse/constraints/kinds/perpendicular.h"
#include "cfuse/constraints/kinds/planar_joint.h"
#include "cfuse/constraints/kinds/prismatic_joint.h"
#include "cfuse/constraints/kinds/revolute_joint.h"
#include "cfuse/constraints/kinds/rigid.h"
#include "cfuse/constraints/kinds/spherical_joint.h"
#include "cfuse/kernel/check.h"

namespace cfuse {

const std::vector<RelationKind>& AllRelations() {
  static const std::vector<RelationKind> kRelations = {
      {"parallel", 2, 2, "parallel(u, v): two vectors", &ParallelResidual::Create},
      {"perpendicular", 2, 2, "perpendicular(u, v): two vectors", &PerpendicularResidual::Create},
      {"coplanar", 4, -1, "coplanar(a, b, c, d, ...): four or more points",
       &CoplanarResidual::Create},
      {"collinear", 3, -1, "collinear(a, b, c, ...): three or more points",
       &CollinearResidual::Create},
      {"rigid", 2, -1, "rigid(p1, p2, ...): two or more points", &RigidResidual::Create},
  };
  return kRelations;
}

const RelationKind* FindRelation(std::string_view name) {
  for (const RelationKind& k : AllRelations()) {
    if (name == k.name) return &k;
  }
  return nullptr;
}

std::shared_ptr<const ResidualFunction> MakeJointResidual(JointType type,
                                                          const JointGeometry& geometry) {
  const std::string name = JointTypeName(type);
  switch (type) {
    case JointType::kRevolute:
    case JointType::kContinuous:
      return std::make_shared<JointResidual<RevoluteJoint>>(geometry, name);
    case JointType::kPrismatic:
      return std::make_shared<JointResidual<PrismaticJoint>>(geometry, name);
    case JointType::kSpherical:
      return std::make_shared<JointResidual<SphericalJoint>>(geometry, name);
    case JointType::kFixed:
      return std::make_shared<JointResidual<FixedJoint>>(geometry, name);
    case JointType::kPlanar:
      return std::make_shared<JointResidual<PlanarJoint>>(geometry, name);
    case JointType::kFloating:
      break;  // constrains nothing: no residual
  }
  CFUSE_CHECK_MSG(false, "unknown joint type");
  return nullptr;
}

}  // namespace cfuse
