// Builds a ConstraintGraph step by step, with the checks every model front end needs:
// unique names, valid identifiers, joints between rigid components without cycles, and
// constraints whose residual and Jacobian are finite at the nominal geometry. Each check
// failure is an InputError at the SourceLocation the caller gave for the offending item.
//
// Used by the model DSL (dsl/) and by importers (URDF), which stay independent of each other:
// a model that includes another file merges that file's graph with Merge().
#pragma once

#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "cfuse/constraints/graph.h"
#include "cfuse/constraints/kinds/kind.h"

namespace cfuse {

struct JointSpec {
  std::string name;
  JointType type = JointType::kFixed;
  int parent = -1, child = -1;  // component indices
  Rigid3d parent_from_joint;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  // in the joint frame; normalised here
  std::optional<std::pair<double, double>> limits;  // rad or m
  double position = 0;                              // q at the nominal geometry
  SourceLocation where;
};

class ModelBuilder {
 public:
  ModelBuilder(std::string model_name, std::string source);

  const ConstraintGraph& graph() const { return graph_; }

  // Resource bounds on one model (includes counted in), refused with an InputError beyond.
  static constexpr int kMaxComponents = 100000;
  static constexpr int kMaxFeaturePoints = 1000000;
  static constexpr int kMaxConstraints = 200000;

  // Hashed look-ups by name; -1 if absent.
  int FindComponent(const std::string& name) const;
  int FindJoint(const std::string& name) const;
  int FindConstraint(const std::string& name) const;
  // What a bare point name can mean: (component, feature point index), the index -1 for a
  // single-point component. Empty if nothing has that name.
  const std::vector<std::pair<int, int>>& FindBarePoint(const std::string& name) const;

  // Names are identifiers: [A-Za-z_][A-Za-z0-9_]*. `what` names the item in messages.
  static bool IsIdentifier(std::string_view name);
  static void RequireIdentifier(const std::string& name, const char* what,
                                const SourceLocation& where);

  int AddPointComponent(const std::string& name, const Eigen::Vector3d& position,
                        const SourceLocation& where);
  // Without a pose the component sits at the identity until a joint places it.
  int AddRigidComponent(const std::string& name, const std::optional<Rigid3d>& world_from_component,
                        const SourceLocation& where);
  void SetNominalPose(int component, const Rigid3d& world_from_component);
  int AddFeaturePoint(int component, const std::string& name, const Eigen::Vector3d& position,
                      const SourceLocation& where);
  // A named frame on a rigid component (a merged URDF link); its name is unique among
  // components and frames.
  void AddFrame(int component, const std::string& name, const Rigid3d& component_from_frame,
                const SourceLocation& where);
  // A rigid component (identity) or a frame on one; nullopt if neither.
  std::optional<std::pair<int, Rigid3d>> FindFrame(const std::string& name) const;
  void AddEdge(int component, const std::string& name, int a, int b, const SourceLocation& where);
  void AddFace(int component, const std::string& name, std::vector<int> loop,
               const SourceLocation& where);

  // Adds the joint and its constraints (and a limit constraint if it has limits). If the
  // child's pose was not given, it becomes parent * parent_from_joint * Motion(q0) and
  // child_from_joint the identity (URDF's convention); otherwise the child keeps its pose and
  // child_from_joint is chosen so that the joint is at q0 in the nominal geometry. Add a
  // parent's joint before its children's.
  int AddJoint(const JointSpec& spec);
  // Records a joint an importer merged away (graph.h, MergedJoint).
  void AddMergedJoint(const std::string& name, std::optional<double> locked_at,
                      const SourceLocation& where);
  // Makes joint `follower` mimic `leader`: q_f = multiplier * q_l + offset, one constraint
  // named FOLLOWER_mimic. Both need a joint variable; chains of mimics must not close.
  void AddMimic(int follower, int leader, double multiplier, double offset,
                const SourceLocation& where);

  // A slack block for a constraint about to be added.
  int AddSlack(const std::string& constraint_name);
  void SetSlackNominal(int slack_block, double value);

  // Adds a constraint; throws InputError at `where` if its residual or Jacobian is not finite
  // at the nominal geometry. Returns its index.
  int AddConstraint(const std::string& name, ConstraintKind kind, const std::string& kind_name,
                    ConstraintParts parts, const SourceLocation& where);
  // A free name for a constraint: `preferred` if unused, else preferred_2, preferred_3, ...
  std::string UniqueConstraintName(const std::string& preferred) const;

  // Fixes a rigid component's position and/or orientation in the world at `target`.
  int FixComponent(int component, bool position, bool orientation, const Rigid3d& target,
                   const SourceLocation& where);

  KindContext Context(int slack_block = -1) const;

  // Appends another graph, every name prefixed with `prefix`. Name clashes are errors at
  // `where` (the include).
  void Merge(const ConstraintGraph& other, const std::string& prefix, const SourceLocation& where);

  ConstraintGraph Build() &&;

 private:
  int AddBlock(BlockKind kind, const std::string& name);
  void RequireUniqueComponent(const std::string& name, const SourceLocation& where) const;
  void RequireUniqueConstraint(const std::string& name, const SourceLocation& where) const;

  void IndexComponent(int component);

  ConstraintGraph graph_;
  std::unordered_map<std::string, int> component_index_, joint_index_, constraint_index_;
  std::unordered_map<std::string, std::pair<int, int>> frame_index_;  // (component, frame)
  std::unordered_set<std::string> merged_joint_names_;
  std::unordered_set<std::string> edge_keys_, face_keys_;  // PartKey(component, name)
  std::unordered_map<std::string, std::vector<std::pair<int, int>>> bare_points_;
  int num_feature_points_ = 0;
  int tangent_dim_ = 0;
};

}  // namespace cfuse
