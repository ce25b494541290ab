#include "cfuse/constraints/kinds/registry.h"

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/collinear.h"
#include "cfuse/constraints/kinds/coplanar.h"
#include "cfuse/constraints/kinds/parallel.h"
#include "cfuse/constraints/kinds/perpendicular.h"
#include "cfuse/constraints/kinds/rigid.h"
#include "cfuse/kernel/check.h"

namespace cfuse {

const std::vector<RelationKind>& AllRelations() {
  static const std::vector<RelationKind> kRelations = {
      {"parallel", ConstraintKind::kRelation, RelationKind::Argument::kVector, 2, 2,
       "parallel(u, v): two vectors", &ParallelResidual::Create},
      {"perpendicular", ConstraintKind::kRelation, RelationKind::Argument::kVector, 2, 2,
       "perpendicular(u, v): two vectors", &PerpendicularResidual::Create},
      {"coplanar", ConstraintKind::kRelation, RelationKind::Argument::kPoint, 4, -1,
       "coplanar(a, b, c, d, ...): four or more points", &CoplanarResidual::Create},
      {"collinear", ConstraintKind::kRelation, RelationKind::Argument::kPoint, 3, -1,
       "collinear(a, b, c, ...): three or more points", &CollinearResidual::Create},
      {"rigid", ConstraintKind::kRigid, RelationKind::Argument::kPoint, 2, -1,
       "rigid(p1, p2, ...): two or more points", &RigidResidual::Create},
  };
  return kRelations;
}

std::string RelationNames() {
  std::string names;
  for (const RelationKind& k : AllRelations())
    names += (names.empty() ? "" : ", ") + std::string(k.name);
  return names;
}

const RelationKind* FindRelation(std::string_view name) {
  for (const RelationKind& k : AllRelations()) {
    if (name == k.name) return &k;
  }
  return nullptr;
}

std::shared_ptr<const ResidualFunction> MakeJointResidual(JointType type,
                                                          const JointGeometry& geometry) {
  std::shared_ptr<const ResidualFunction> residual =
      ModelOf(type).MakeResidual(geometry, JointTypeName(type));
  CFUSE_CHECK_MSG(residual != nullptr, "a floating joint constrains nothing: it has no residual");
  return residual;
}

}  // namespace cfuse
