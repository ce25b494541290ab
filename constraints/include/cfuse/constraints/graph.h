// The symbolic constraint graph: an immutable model of a constrained object.
//
// Built by the model DSL (dsl/) or an importer through ModelBuilder, then only read. It holds
//   - blocks: the variables (values.h), one per component plus one slack per inequality;
//   - components: single-point (one kPoint block) or rigid (one kPose block) with named feature
//     points in component coordinates, edges and faces;
//   - joints between rigid components (each also a constraint, and limits a second one);
//   - constraints: residual functions over blocks, zero when the constraint holds (Hel-Or &
//     Werman's ψ_k(T) = 0, inequalities already in slack form g(x) - λ² = 0);
//   - nominal: the model's geometry, a Values that is also the default initial guess.
// Working data (estimates, covariances) lives elsewhere: model apart from data.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "cfuse/kernel/error.h"
#include "cfuse/kernel/residual.h"
#include "cfuse/kernel/rigid3.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

struct FeaturePoint {
  std::string name;
  Eigen::Vector3d position;  // in component coordinates
  SourceLocation where;
};

struct Edge {
  std::string name;
  int a = 0, b = 0;  // indices into Component::points
  SourceLocation where;
};

// A planar polygon; its loop runs counter-clockwise seen from outside the object (right-hand
// rule gives the outward normal).
struct Face {
  std::string name;
  std::vector<int> loop;  // indices into Component::points
  SourceLocation where;
};

// A named frame fixed on a rigid component: a URDF link merged into the component of the link
// it is fixed to, kept so that forward kinematics and results still report its pose.
struct ComponentFrame {
  std::string name;
  Rigid3d component_from_frame;
  SourceLocation where;
  // Another name look-ups accept: the model files' identifier for a name the source spells
  // otherwise (a URDF's link 'arm-1' is 'arm_1' in a model that includes it), or "".
  std::string alias;
};

struct Component {
  std::string name;    // as the source file spells it
  bool rigid = false;  // rigid: 6-DOF pose block; otherwise one 3-DOF point block (§5)
  // A rigid component's nominal pose was given (or set by a joint); when not, a joint whose
  // child it is places it.
  bool pose_given = false;
  int block = -1;
  std::vector<FeaturePoint> points;  // rigid only; a single-point component has none
  std::vector<Edge> edges;
  std::vector<Face> faces;
  std::vector<ComponentFrame> frames;  // rigid only; names unique among components and frames
  SourceLocation where;
  // Point name -> index into `points`, kept by ModelBuilder, so that resolving a label or a
  // reference does not scan a component of 10^5 points. A graph assembled by hand may leave it
  // empty: FindPoint then scans.
  std::unordered_map<std::string, int> point_index;

  int FindPoint(std::string_view point_name) const;  // -1 if absent
  // Another name look-ups accept: the model files' identifier for a name the source spells
  // otherwise (a URDF's link 'arm-1' is 'arm_1' in a model that includes it), or "".
  std::string alias;
};

// URDF's joint types and the spherical joint. A floating joint constrains nothing; a planar one
// keeps the child moving in the plane normal to its axis.
enum class JointType { kRevolute, kContinuous, kPrismatic, kSpherical, kFixed, kPlanar, kFloating };
const char* JointTypeName(JointType type);
std::optional<JointType> ParseJointType(std::string_view name);
// True for joint types with a scalar joint variable (revolute, continuous, prismatic).
bool HasJointVariable(JointType type);
// Motion(q) of a joint with a variable (below); the identity for the other types.
Rigid3d JointMotion(JointType type, const Eigen::Vector3d& axis, double q);

// The joint frame J is fixed on both sides: parent_from_joint on the parent and
// child_from_joint on the child. The joint holds when
//   (world_from_parent * parent_from_joint)^-1 * (world_from_child * child_from_joint)
//     = Motion(q),
// Motion(q) a rotation by q about `axis` (revolute, continuous), a translation by q along it
// (prismatic), any rotation (spherical), the identity (fixed), a rotation about `axis` and a
// translation normal to it (planar) or anything (floating).
//
// A mimic joint's variable follows another's: q = multiplier * q_leader + offset (URDF's
// <mimic>), one more constraint.
struct JointMimic {
  int leader = -1;  // joint index
  double multiplier = 1, offset = 0;
  int constraint = -1;
};

struct Joint {
  std::string name;
  JointType type = JointType::kFixed;
  int parent = -1, child = -1;  // component indices
  Rigid3d parent_from_joint;
  Rigid3d child_from_joint;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  // unit, in the joint frame
  std::optional<std::pair<double, double>> limits;  // [lower, upper] in rad or m
  double nominal_position = 0;                      // q at the nominal geometry
  int constraint = -1;        // index of the joint's constraint (-1: floating)
  int limit_constraint = -1;  // index of its limit constraint, or -1
  std::optional<JointMimic> mimic;
  SourceLocation where;
  // Another name look-ups accept: the model files' identifier for a name the source spells
  // otherwise (a URDF's link 'arm-1' is 'arm_1' in a model that includes it), or "".
  std::string alias;
};

// A joint an importer merged away (URDF: fixed, or revolute/prismatic with lower = upper,
// locked at that value): no constraint, but forward kinematics accepts its value.
struct MergedJoint {
  std::string name;
  std::optional<double> locked_at;  // none: a fixed joint
  SourceLocation where;
  // Another name look-ups accept: the model files' identifier for a name the source spells
  // otherwise (a URDF's link 'arm-1' is 'arm_1' in a model that includes it), or "".
  std::string alias;
};

// What a constraint states, for the algorithms that treat some statements apart: the fusion
// order's rigid triangles (distances, rigid sets), the distance anchors of a single point seen
// from one image, a simulation's fixed entries, forward kinematics' fixed roots.
enum class ConstraintKind {
  kExpression,        // an expression compared: ==, <=, >=, in (other than the one below)
  kDistanceEquality,  // distance(a, b) == ...
  kRelation,          // parallel, perpendicular, coplanar, collinear
  kRigid,             // rigid(p1, p2, ...)
  kFixed,             // a pose, position, orientation or point fixed in the world
  kJoint,
  kJointLimit,
  kMimicJoint,
};

struct Constraint {
  std::string name;
  ConstraintKind kind = ConstraintKind::kExpression;
  // The kind for people: "distance ==", "parallel", "revolute joint", "joint limit".
  std::string kind_name;
  // A kFixed constraint holding both position and orientation: the pose it holds.
  std::optional<Rigid3d> fixed_pose;
  std::shared_ptr<const ResidualFunction> residual;
  std::vector<int> blocks;  // the residual's slots: block ids
  int slack_block = -1;     // the slack of an inequality (also among `blocks`), or -1
  SourceLocation where;
  // Rows of the relation as written that the constraints before it already imply, left out
  // of `residual` (constraints/src/row_selection.h).
  int redundant_rows = 0;
};

struct ConstraintGraph {
  std::string name;    // the model's name
  std::string source;  // the file it came from
  std::vector<Block> blocks;
  std::vector<Component> components;
  std::vector<Joint> joints;
  std::vector<MergedJoint> merged_joints;
  std::vector<Constraint> constraints;
  Values nominal;

  int tangent_dim() const;
  int num_equations() const;  // sum of the constraints' dimensions
  // By name or alias; -1 if absent.
  int FindComponent(std::string_view name) const;
  int FindJoint(std::string_view name) const;
  const MergedJoint* FindMergedJoint(std::string_view name) const;  // nullptr if absent
  int FindConstraint(std::string_view name) const;
  // A component's frame, or a frame on a component: (component, component_from_frame); the
  // component's own name gives the identity. nullopt if neither.
  std::optional<std::pair<int, Rigid3d>> FindFrame(std::string_view name) const;
  // The names of a constraint's slots, for ResidualFunction::Describe.
  std::vector<std::string> SlotNames(const Constraint& c) const;
  std::string Describe(const Constraint& c) const;
};

// Contract at the entry points of the algorithms (InternalError if broken): the nominal values
// fit the blocks, each component's block is of its kind, and each constraint's residual takes
// its blocks.
void CheckGraph(const ConstraintGraph& graph);

}  // namespace cfuse
