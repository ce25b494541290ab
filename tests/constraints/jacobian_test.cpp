// Every constraint kind and every built-in function: autodiff Jacobian against central
// differences, at random configurations all over SO(3).
#include <catch2/catch.hpp>
#include <functional>
#include <random>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/kinds/inequality.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/constraints/kinds/range.h"
#include "cfuse/constraints/kinds/registry.h"
#include "cfuse/constraints/model_builder.h"
#include "constraints/jacobian_checker.h"

namespace cfuse {
namespace {

Rigid3d RandomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return Rigid3d(q.normalized(), Eigen::Vector3d(n(rng), n(rng), n(rng)));
}

Eigen::Vector3d RandomVector(std::mt19937& rng, double scale = 1.0) {
  std::normal_distribution<double> n(0, scale);
  return {n(rng), n(rng), n(rng)};
}

// A scene of five rigid components (A..E, two feature points each) and four single points.
struct Scene {
  explicit Scene(unsigned seed) : rng(seed), builder("scene", "test") {
    for (const char* name : {"A", "B", "C", "D", "E"}) {
      const int c = builder.AddRigidComponent(name, RandomPose(rng), {});
      builder.AddFeaturePoint(c, "a", RandomVector(rng, 0.3), {});
      builder.AddFeaturePoint(c, "b", RandomVector(rng, 0.3), {});
    }
    for (const char* name : {"p", "q", "r", "s"})
      builder.AddPointComponent(name, RandomVector(rng), {});
  }
  ExprPtr F(const char* comp, const char* point) const {
    const ConstraintGraph& g = builder.graph();
    const Component& c = g.components[g.FindComponent(comp)];
    const int i = c.FindPoint(point);
    return MakeFeatureRef(c.block, c.points[i].position, point);
  }
  ExprPtr P(const char* name) const {
    const ConstraintGraph& g = builder.graph();
    return MakePointRef(g.components[g.FindComponent(name)].block);
  }
  int Comp(const char* name) const { return builder.graph().FindComponent(name); }
  static ExprPtr Sub(ExprPtr a, ExprPtr b) {
    std::string why;
    return MakeBinary(Expr::Op::kSub, a, b, &why);
  }
  static ExprPtr Call(Function f, std::vector<ExprPtr> args) {
    std::string why;
    ExprPtr e = MakeCall(f, std::move(args), &why);
    REQUIRE(e);
    return e;
  }
  void Equal(const std::string& name, ExprPtr lhs) {
    ExprPtr rhs = lhs->type.vector ? MakeVectorConstant({0.1, 0.2, 0.3}, lhs->type.quantity)
                                   : MakeConstant(0.25, lhs->type.quantity);
    builder.AddConstraint(name, ConstraintKind::kExpression, "test",
                          EqualityResidual::Create(lhs, rhs, builder.Context()), {});
  }
  void Relation(const std::string& name, const char* relation, std::vector<ExprPtr> args) {
    builder.AddConstraint(name, FindRelation(relation)->kind, relation,
                          FindRelation(relation)->create(std::move(args), builder.Context()), {});
  }

  std::mt19937 rng;
  ModelBuilder builder;
};

using Builder = std::function<void(Scene&)>;

const std::vector<std::pair<const char*, Builder>>& Cases() {
  static const std::vector<std::pair<const char*, Builder>> cases = {
      {"distance",
       [](Scene& s) {
         s.Equal("k", Scene::Call(Function::kDistance, {s.F("A", "a"), s.P("p")}));
       }},
      {"angle",
       [](Scene& s) {
         s.Equal("k", Scene::Call(Function::kAngle, {s.F("A", "a"), s.F("B", "b"), s.P("p")}));
       }},
      {"angle_between",
       [](Scene& s) {
         s.Equal("k",
                 Scene::Call(Function::kAngleBetween, {Scene::Sub(s.F("A", "a"), s.F("B", "b")),
                                                       Scene::Sub(s.P("p"), s.P("q"))}));
       }},
      {"dot",
       [](Scene& s) {
         s.Equal("k", Scene::Call(Function::kDot, {Scene::Sub(s.F("A", "a"), s.P("p")),
                                                   Scene::Sub(s.F("B", "b"), s.P("q"))}));
       }},
      {"cross",
       [](Scene& s) {
         s.Equal("k", Scene::Call(Function::kCross, {Scene::Sub(s.F("A", "a"), s.P("p")),
                                                     Scene::Sub(s.F("B", "b"), s.P("q"))}));
       }},
      {"norm",
       [](Scene& s) {
         s.Equal("k", Scene::Call(Function::kNorm, {Scene::Sub(s.F("A", "a"), s.F("B", "b"))}));
       }},
      {"arithmetic",
       [](Scene& s) {
         std::string why;
         ExprPtr d1 = Scene::Call(Function::kDistance, {s.P("p"), s.P("q")});
         ExprPtr d2 = Scene::Call(Function::kDistance, {s.F("A", "a"), s.F("B", "b")});
         ExprPtr e =
             MakeBinary(Expr::Op::kSub, MakeBinary(Expr::Op::kMul, MakeConstant(2, {}), d1, &why),
                        MakeBinary(Expr::Op::kDiv, d2, MakeConstant(3, {}), &why), &why);
         ExprPtr v = MakeBinary(Expr::Op::kAdd, MakeNeg(s.P("r")),
                                MakeBinary(Expr::Op::kMul, s.F("C", "a"),
                                           MakeBinary(Expr::Op::kDiv, d1, d2, &why), &why),
                                &why);
         s.Equal("k", MakeBinary(Expr::Op::kDiv, e, d1, &why));
         s.Equal("v", v);
         s.Equal("lit", MakeVector({d1, d2, MakeConstant(0.5, Quantity::Length())}, &why));
       }},
      {"inequality",
       [](Scene& s) {
         const int slack = s.builder.AddSlack("k");
         double s0 = 0;
         ConstraintParts parts = InequalityResidual::Create(
             Scene::Call(Function::kDistance, {s.P("p"), s.F("B", "a")}),
             MakeConstant(0.1, Quantity::Length()), true, s.builder.Context(slack), &s0);
         s.builder.SetSlackNominal(slack, 0.7);
         s.builder.AddConstraint("k", ConstraintKind::kExpression, "test", std::move(parts), {});
       }},
      {"range",
       [](Scene& s) {
         const int slack = s.builder.AddSlack("k");
         double s0 = 0;
         ConstraintParts parts = RangeResidual::Create(
             Scene::Call(Function::kAngle, {s.P("p"), s.F("B", "a"), s.F("C", "b")}), 0.2, 2.5,
             s.builder.Context(slack), &s0);
         s.builder.SetSlackNominal(slack, 0.4);
         s.builder.AddConstraint("k", ConstraintKind::kExpression, "test", std::move(parts), {});
       }},
      {"parallel",
       [](Scene& s) {
         s.Relation(
             "k", "parallel",
             {Scene::Sub(s.F("A", "a"), s.F("A", "b")), Scene::Sub(s.F("B", "a"), s.P("p"))});
       }},
      {"perpendicular",
       [](Scene& s) {
         s.Relation("k", "perpendicular",
                    {Scene::Sub(s.F("A", "a"), s.P("q")), Scene::Sub(s.F("B", "a"), s.P("p"))});
       }},
      {"coplanar",
       [](Scene& s) {
         s.Relation("k", "coplanar", {s.P("p"), s.P("q"), s.F("A", "a"), s.F("B", "b"), s.P("r")});
       }},
      {"coplanar, arity 30 (chunked autodiff)",
       [](Scene& s) {
         s.Relation("k", "coplanar",
                    {s.F("A", "a"), s.F("B", "a"), s.F("C", "a"), s.F("D", "a"), s.F("E", "a")});
       }},
      {"collinear",
       [](Scene& s) {
         s.Relation("k", "collinear", {s.P("p"), s.F("A", "a"), s.F("B", "b"), s.P("q")});
       }},
      {"rigid",
       [](Scene& s) {
         s.Relation("k", "rigid", {s.P("p"), s.P("q"), s.F("A", "a"), s.F("B", "b"), s.P("r")});
       }},
      {"fixed pose",
       [](Scene& s) { s.builder.FixComponent(s.Comp("A"), true, true, RandomPose(s.rng), {}); }},
      {"fixed orientation",
       [](Scene& s) { s.builder.FixComponent(s.Comp("B"), false, true, RandomPose(s.rng), {}); }},
  };
  return cases;
}

void CheckAllConstraints(Scene& scene) {
  const ConstraintGraph& graph = scene.builder.graph();
  REQUIRE(!graph.constraints.empty());
  // At the nominal geometry and at two other random configurations.
  std::vector<Values> configurations = {graph.nominal};
  for (int k = 0; k < 2; ++k) {
    Values v = graph.nominal;
    for (Rigid3d& pose : v.poses) pose = RandomPose(scene.rng);
    for (Eigen::Vector3d& p : v.points) p = RandomVector(scene.rng);
    for (double& s : v.slacks) s = 0.5 + 0.1 * k;
    configurations.push_back(v);
  }
  for (const Constraint& c : graph.constraints) {
    for (const Values& at : configurations) {
      INFO("constraint " << c.name << ": " << graph.Describe(c));
      testing::CheckJacobian(graph, *c.residual, c.blocks, at);
    }
  }
}

TEST_CASE("jacobian: every function and constraint kind matches central differences",
          "[constraints]") {
  for (const auto& [name, build] : Cases()) {
    for (unsigned seed = 1; seed <= 3; ++seed) {
      DYNAMIC_SECTION(name << ", seed " << seed) {
        Scene scene(seed);
        build(scene);
        CheckAllConstraints(scene);
      }
    }
  }
}

// Every relation of the registry, with sample arguments of the sort it takes: a relation added
// there is checked here without a line of its own.
TEST_CASE("jacobian: every registered relation, at its fewest arguments and more",
          "[constraints]") {
  REQUIRE(AllRelations().size() >= 5);
  for (const RelationKind& kind : AllRelations()) {
    const int most = kind.max_args >= 0 ? kind.max_args : kind.min_args + 2;
    for (int n = kind.min_args; n <= most; ++n) {
      for (unsigned seed = 1; seed <= 2; ++seed) {
        DYNAMIC_SECTION(kind.name << " of " << n << ", seed " << seed) {
          Scene scene(seed);
          // Feature points of rigid components and single points in turn; a vector is the
          // difference of two of them.
          const std::vector<ExprPtr> points = {
              scene.F("A", "a"), scene.P("p"),      scene.F("B", "b"),
              scene.P("q"),      scene.F("C", "a"), scene.P("r"),
              scene.F("D", "b"), scene.P("s"),      scene.F("E", "a")};
          std::vector<ExprPtr> args;
          for (int i = 0; i < n; ++i) {
            args.push_back(kind.argument == RelationKind::Argument::kPoint
                               ? points.at(i)
                               : Scene::Sub(points.at(2 * i), points.at(2 * i + 1)));
          }
          scene.builder.AddConstraint("k", kind.kind, kind.name,
                                      kind.create(std::move(args), scene.builder.Context()), {});
          CHECK(scene.builder.graph().constraints[0].kind == kind.kind);
          CheckAllConstraints(scene);
        }
      }
    }
  }
}

TEST_CASE("jacobian: every joint type, its variable and its limits", "[constraints]") {
  for (JointType type : {JointType::kRevolute, JointType::kContinuous, JointType::kPrismatic,
                         JointType::kSpherical, JointType::kFixed}) {
    for (unsigned seed = 1; seed <= 3; ++seed) {
      DYNAMIC_SECTION(JointTypeName(type) << ", seed " << seed) {
        Scene scene(seed);
        JointSpec spec;
        spec.name = "j";
        spec.type = type;
        spec.parent = scene.Comp("A");
        spec.child = scene.Comp("B");
        spec.parent_from_joint = RandomPose(scene.rng);
        spec.axis = RandomVector(scene.rng);
        if (HasJointVariable(type)) spec.position = 0.3;
        if (type == JointType::kRevolute) spec.limits = std::make_pair(-0.5, 1.2);
        if (type == JointType::kPrismatic) spec.limits = std::make_pair(-0.1, 0.6);
        scene.builder.AddJoint(spec);
        const ConstraintGraph& graph = scene.builder.graph();
        REQUIRE(graph.constraints.size() == (spec.limits ? 2u : 1u));
        CheckAllConstraints(scene);
        if (HasJointVariable(type)) {
          const Joint& joint = graph.joints[0];
          const JointValueFunction q(
              JointGeometry(joint.parent_from_joint, joint.child_from_joint, joint.axis),
              type == JointType::kPrismatic);
          const std::vector<int> blocks = {graph.components[joint.parent].block,
                                           graph.components[joint.child].block};
          testing::CheckJacobian(graph, q, blocks, graph.nominal);
          // The joint variable reads back the nominal position.
          Eigen::VectorXd value;
          EvaluateResidual(q, graph.blocks, blocks, graph.nominal, &value, nullptr);
          CHECK(value[0] == Approx(0.3).margin(1e-12));
        }
      }
    }
  }
}

}  // namespace
}  // namespace cfuse
