// Residual functions: the one interface behind every constraint (and, later, measurement).
//
// A ResidualFunction maps the values of the blocks it touches (its "slots", in a fixed order
// held by whoever owns it, e.g. ConstraintGraph's Constraint::blocks) to a residual vector
// r ∈ R^dimension(). A constraint holds when r = 0. Residuals are written once, templated on
// the scalar, and differentiated automatically: derive from AutoDiffResidual<Derived> and give
//
//   template <typename T>
//   void Compute(std::span<const BlockState<T>> x, T* residual) const;
//
// Convert constants with T(k). The Jacobian with respect to each slot's tangent coordinates
// (see values.h for the chart) comes from cfuse/constraints/evaluate.h, never from hand derivation.
#pragma once

#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

#include "cfuse/kernel/jet.h"
#include "cfuse/kernel/so3.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

// One block's value in scalar T. Pose: R = world_R_component, t = world_t_component.
// Point: t is the position (R unused). Slack: t.x() is λ (R unused).
template <typename T>
struct BlockState {
  Matrix3<T> R;
  Vector3<T> t;
  const T& slack() const { return t.x(); }
};

// A model point in the world: a single-point component's position (on_pose false), or the
// feature point at `position_in_component` of a rigid component, R x + t.
template <typename T>
Vector3<T> ModelPointInWorld(const BlockState<T>& s, bool on_pose,
                             const Eigen::Vector3d& position_in_component) {
  return on_pose ? Vector3<T>(s.R * position_in_component.cast<T>() + s.t) : s.t;
}

class ResidualFunction {
 public:
  virtual ~ResidualFunction() = default;

  int dimension() const { return dimension_; }
  // The kind of block each slot must hold.
  const std::vector<BlockKind>& slot_kinds() const { return slot_kinds_; }
  int arity() const;  // sum of the slots' tangent dimensions
  // True if the residual is affine in its slots' tangent coordinates (values.h's chart), so
  // that one Kalman update fuses it exactly and local iterations are unnecessary.
  virtual bool is_linear() const { return false; }

  virtual void Evaluate(std::span<const BlockState<double>> x, double* residual) const = 0;
  virtual void Evaluate(std::span<const BlockState<Jet>> x, Jet* residual) const = 0;

  // Human-readable form, e.g. "distance(arm.tip, p3) == 0.25 m", given each slot's name.
  virtual std::string Describe(std::span<const std::string> slot_names) const = 0;

 protected:
  ResidualFunction(int dimension, std::vector<BlockKind> slot_kinds)
      : dimension_(dimension), slot_kinds_(std::move(slot_kinds)) {}

 private:
  int dimension_;
  std::vector<BlockKind> slot_kinds_;
};

template <class Derived>
class AutoDiffResidual : public ResidualFunction {
 public:
  void Evaluate(std::span<const BlockState<double>> x, double* residual) const final {
    static_cast<const Derived*>(this)->Compute(x, residual);
  }
  void Evaluate(std::span<const BlockState<Jet>> x, Jet* residual) const final {
    static_cast<const Derived*>(this)->Compute(x, residual);
  }

 protected:
  using ResidualFunction::ResidualFunction;
};

}  // namespace cfuse
