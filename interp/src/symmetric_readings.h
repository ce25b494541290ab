// Other readings of one configuration: relabellings of a model's points under which the same
// point positions are again a configuration of the model.
//
// A rigid component's data are its points; where another component's points, or its own in
// another order, have the same shape, a configuration can be read with the two exchanged or
// the part turned onto itself, and every point stays where it was: the scissors' mirror-image
// blades exchanged, a Stewart platform turned by a third, a folding ruler of identical
// segments read from its other end. Point data cannot tell such readings apart, except through
// the constraints, which the turned or exchanged parts may break. This finds the readings whose
// constraints still hold (or nearly: a re-fit may repair a small violation), so that an
// interpretation can list the ones its fit test does not reject instead of choosing one by
// chance.
//
// A reading maps every rigid component c onto a component d with the same number of points
// and a point bijection f that a proper rigid motion F realises (d's point f(i) at F times c's
// point i, to a tolerance); c then takes the pose
// world_from_d * F, which puts each of its points where d's point f(i) was. Single-point
// components keep their place.
#pragma once

#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/rigid3.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

struct Reading {
  // Per component: the component whose place its points take (itself for a single point), and
  // per point, the index of the point of that component it now sits on.
  std::vector<int> source_component;
  std::vector<std::vector<int>> source_point;
  Values mean;             // the configuration so read, slacks matched to it
  double violation = 0;    // the largest constraint violation there (0: an exact symmetry)
};

class SymmetricReadings {
 public:
  // The congruences between the graph's rigid components (computed once; the graph must
  // outlive this), each holding to `tolerance` (metres) or a thousandth of the component's
  // size, whichever is larger. Data with noise σ cannot tell apart points closer than a few σ:
  // a folding ruler's segment turned end for end puts its corners 3 mm off their places, which
  // 2 mm noise hides, and a ruler read from its other end fits nearly as well.
  explicit SymmetricReadings(const ConstraintGraph& graph, double tolerance = 0);

  // Whether some component has a congruence other than its identity: without, no reading
  // other than the configuration itself exists.
  bool any() const { return any_; }

  // The readings of `configuration` other than itself whose every constraint is violated by at
  // most `tolerance` (in the residual's own units: metres, or a rotation's sine), least
  // violated first, at most `max_readings`. The search visits at most a few thousand partial
  // readings and stops there.
  std::vector<Reading> Find(const Values& configuration, double tolerance,
                            int max_readings) const;

 private:
  struct Congruence {
    int target = -1;
    std::vector<int> point_map;  // source point i -> target point point_map[i]
    Rigid3d target_from_source;
  };

  const ConstraintGraph* graph_;
  std::vector<std::vector<Congruence>> options_;  // per component, the identity first
  std::vector<int> order_;                        // rigid components, each next to one before
  // Per position in order_, the constraints whose rigid components are all placed there, and
  // the joints.
  std::vector<std::vector<int>> complete_at_;
  std::vector<std::vector<int>> joints_at_;
  bool any_ = false;
};

}  // namespace cfuse
