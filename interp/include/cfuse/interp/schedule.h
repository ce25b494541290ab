// The fusion order of Hel-Or & Werman (1994) §6, in its component form of §7: which
// constraints are fused before which model point is matched, so that every match is predicted
// from as much as possible of what was fused before it.
//
// The paper's loop, with components in place of points (a single-point component is one point):
//   (a) fuse every constraint all of whose components are matched;
//   (b) match every component that a fused constraint touches (a rigid component: all its
//       feature points, one level each);
//   (c) fuse one constraint touching a matched component, or else
//   (d) fuse some constraint;
// until no constraint or no component is left. Components no constraint touches are matched
// last, and constraints left over are fused after the last match.
//
// The paper leaves the choices in (c), (d) and the order inside (b) open. Ours, deterministic:
//   (c) the constraint with the fewest unmatched components (so that the next match is
//       predicted by it), then the most matched ones, then the first in model order;
//   (d) at the start, a constraint on the start component: the rigid component with the most
//       feature points, or, in a model of single points, the best-shaped rigid triangle (three
//       points pairwise held by `distance == nominal` or one `rigid(...)`; largest smallest
//       side, then model order), whose first side is fused first; later, the first constraint
//       in model order;
//   (b) components in model order; a rigid component's features start with its seed set (the
//       3 features spanning the largest triangle, then for 2D data a fourth off their plane)
//       and go on in model order.
// The interpretation tree (interpretation.h) starts from that triangle or seed set: the minimal
// set from which a pose can be computed in closed form.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"

namespace cfuse {

// One level of the interpretation tree: constraints fused just before it, then one model point
// matched.
struct PlanLevel {
  std::vector<int> constraints;  // indices into ConstraintGraph::constraints
  int component = -1;
  int feature = -1;  // index into Component::points; -1 for a single-point component
};

struct FusionPlan {
  std::vector<PlanLevel> levels;
  std::vector<int> trailing;  // constraints fused after the last match
  // The first levels form a set whose pose is computed in closed form from its matches: the
  // start triangle of a point model (3 levels), or a rigid component's seed features (3 or 4).
  int seed_levels = 0;
  bool seed_is_rigid_component = false;
};

// Where a plan starts, instead of the automatic choice: a rigid triangle of single-point
// components, or one rigid component and the features it starts with (its seed set).
struct PlanStart {
  std::vector<int> components;
  std::vector<int> features;  // a rigid start's seed features, in order
};

// The plan for 3D data (seed sets of 3 points) or 2D data (4 points for a rigid component).
FusionPlan PlanFusion(const ConstraintGraph& graph, bool image_data = false,
                      const PlanStart* start = nullptr);

// Triangles of single-point components pairwise held by `distance == nominal` or a common
// `rigid(...)` (constraint k ignored where (*use)[k] is false), best-shaped first: largest
// smallest side, then model order. The first kMaxRigidTriangles found are ranked.
inline constexpr size_t kMaxRigidTriangles = 100000;
std::vector<std::array<int, 3>> RigidTriangles(const ConstraintGraph& graph,
                                               const std::vector<bool>* use = nullptr);

// The components a constraint touches (its blocks that are components', not slacks).
std::vector<int> ConstraintComponents(const ConstraintGraph& graph, const Constraint& c);

// "p3" for a single-point component, "box.c000" for a feature point.
std::string ModelPointName(const ConstraintGraph& graph, int component, int feature);

// `cfuse plan`'s text: level by level, the constraints fused and the point matched.
std::string FormatPlan(const ConstraintGraph& graph, const FusionPlan& plan);

}  // namespace cfuse
