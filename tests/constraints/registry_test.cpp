// The registry of relations and joint residuals: each row found by its name, its argument kinds
// and counts as its factory takes them, the factory building that relation on those arguments'
// blocks; the joint residual of each type, and none for a floating joint.
#include "cfuse/constraints/kinds/registry.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <iterator>
#include <string>

#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

TEST_CASE("registry: every relation by name, with its kind and argument counts", "[constraints]") {
  CHECK(RelationNames() == "parallel, perpendicular, coplanar, collinear, rigid");
  const struct {
    const char* name;
    ConstraintKind kind;
    RelationKind::Argument argument;
    int min_args, max_args;
  } expected[] = {
      {"parallel", ConstraintKind::kRelation, RelationKind::Argument::kVector, 2, 2},
      {"perpendicular", ConstraintKind::kRelation, RelationKind::Argument::kVector, 2, 2},
      {"coplanar", ConstraintKind::kRelation, RelationKind::Argument::kPoint, 4, -1},
      {"collinear", ConstraintKind::kRelation, RelationKind::Argument::kPoint, 3, -1},
      {"rigid", ConstraintKind::kRigid, RelationKind::Argument::kPoint, 2, -1},
  };
  REQUIRE(AllRelations().size() == std::size(expected));
  for (size_t i = 0; i < std::size(expected); ++i) {
    const RelationKind& r = AllRelations()[i];
    INFO(expected[i].name);
    CHECK(std::string(r.name) == expected[i].name);
    CHECK(FindRelation(expected[i].name) == &r);
    CHECK(r.kind == expected[i].kind);
    CHECK(r.argument == expected[i].argument);
    CHECK(r.min_args == expected[i].min_args);
    CHECK(r.max_args == expected[i].max_args);
    CHECK(std::string(r.usage).rfind(std::string(r.name) + "(", 0) == 0);
  }
  CHECK(FindRelation("Parallel") == nullptr);
  CHECK(FindRelation("distance") == nullptr);  // a function, not a relation
}

TEST_CASE("registry: each factory builds its relation on its arguments' blocks", "[constraints]") {
  ModelBuilder b("m", "test");
  const Eigen::Vector3d at[] = {{0, 0, 0}, {1, 0.1, 0}, {0.2, 1, 0.1}, {0.3, 0.4, 1}};
  std::vector<ExprPtr> points, vectors;
  std::vector<std::string> names;
  std::vector<int> blocks;
  std::string why;
  for (int i = 0; i < 4; ++i) {
    names.push_back("p" + std::to_string(i));
    blocks.push_back(b.graph().components[b.AddPointComponent(names.back(), at[i], {})].block);
    points.push_back(MakePointRef(blocks.back()));
  }
  for (int i = 1; i < 4; ++i)
    vectors.push_back(MakeBinary(Expr::Op::kSub, points[i], points[0], &why));
  for (const RelationKind& r : AllRelations()) {
    INFO(r.name);
    const bool on_points = r.argument == RelationKind::Argument::kPoint;
    std::vector<ExprPtr> args(on_points ? points.begin() : vectors.begin(),
                              (on_points ? points.begin() : vectors.begin()) + r.min_args);
    const ConstraintParts parts = r.create(args, b.Context());
    REQUIRE(parts.residual != nullptr);
    CHECK(parts.residual->Describe(names).rfind(std::string(r.name) + "(", 0) == 0);
    const int used = on_points ? r.min_args : r.min_args + 1;  // the vectors share p0
    std::vector<int> expected(blocks.begin(), blocks.begin() + used);
    if (!on_points) std::rotate(expected.begin(), expected.begin() + 1, expected.begin() + 2);
    CHECK(parts.blocks == expected);
    CHECK(parts.residual->slot_kinds() == std::vector<BlockKind>(used, BlockKind::kPoint));
    // A relation on points refuses a bare direction; one on vectors takes it.
    std::vector<ExprPtr> direction = args;
    direction[0] = MakeVectorConstant({0, 0, 1}, Quantity{});
    if (on_points) {
      CHECK_THROWS_AS(r.create(direction, b.Context()), KindError);
    } else {
      CHECK_NOTHROW(r.create(direction, b.Context()));
    }
  }
}

TEST_CASE("registry: the joint residual of each type; a floating joint has none", "[constraints]") {
  const JointGeometry geometry(Rigid3d(), Rigid3d(), Eigen::Vector3d::UnitZ());
  const std::string names[] = {"base", "arm"};
  for (JointType t : {JointType::kRevolute, JointType::kContinuous, JointType::kPrismatic,
                      JointType::kSpherical, JointType::kFixed, JointType::kPlanar}) {
    const auto f = MakeJointResidual(t, geometry);
    REQUIRE(f != nullptr);
    CHECK(f->slot_kinds() == std::vector<BlockKind>{BlockKind::kPose, BlockKind::kPose});
    CHECK(f->Describe(names) == std::string(JointTypeName(t)) + " joint base -> arm");
  }
  CHECK_THROWS_WITH(MakeJointResidual(JointType::kFloating, geometry),
                    Catch::Contains("a floating joint constrains nothing"));
}

}  // namespace
}  // namespace cfuse
