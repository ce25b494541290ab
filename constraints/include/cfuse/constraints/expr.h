// Symbolic expressions over variable blocks: the nodes inside constraints.
//
// An Expr is an immutable tree. Leaves are constants, single-point components (kPoint) and
// feature points of rigid components (kFeature: x_world = R * x_component + t). Inner nodes
// are arithmetic and the built-in functions of functions.h. Every node carries its static
// type (scalar or 3-vector, with a physical Quantity) so that unit errors are caught when the
// model is read, not when it is solved.
//
// Leaves refer to blocks by slot. A tree is first built with graph block ids in the slot
// field ("unbound"); BindSlots() renumbers them 0..k-1 in order of first appearance and
// returns the block ids, which the owning constraint stores. Evaluation is templated on the
// scalar so that Jet gives derivatives.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cfuse/constraints/functions.h"
#include "cfuse/kernel/residual.h"

namespace cfuse {

struct Expr;
using ExprPtr = std::shared_ptr<const Expr>;

struct Expr {
  enum class Op { kConstant, kPoint, kFeature, kVector, kNeg, kAdd, kSub, kMul, kDiv, kCall };
  Op op = Op::kConstant;
  ExprType type;
  Eigen::Vector3d constant = Eigen::Vector3d::Zero();  // kConstant (scalar in x());
                                                       // kFeature: position in the component
  int slot = -1;                                       // kPoint, kFeature
  std::string name;                                    // kFeature: the feature point's name
  Function function = Function::kDistance;             // kCall
  std::vector<ExprPtr> args;  // kVector: 3 scalars; kNeg: 1; binary ops: 2; kCall: its arguments
};

ExprPtr MakeConstant(double value, Quantity q);
ExprPtr MakeVectorConstant(const Eigen::Vector3d& value, Quantity q);
ExprPtr MakePointRef(int slot);
ExprPtr MakeFeatureRef(int slot, const Eigen::Vector3d& position_in_component, std::string name);
// Type-checked constructors: return nullptr with *why set when the operand types do not fit.
ExprPtr MakeVector(std::vector<ExprPtr> scalars, std::string* why);
ExprPtr MakeNeg(ExprPtr a);
ExprPtr MakeBinary(Expr::Op op, ExprPtr a, ExprPtr b, std::string* why);
ExprPtr MakeCall(Function f, std::vector<ExprPtr> args, std::string* why);

// Renumbers the slots of all trees to 0..k-1 in order of first appearance; returns the k
// original slot values (block ids), in the new slot order.
std::vector<int> BindSlots(std::vector<ExprPtr>* exprs);
// True if the tree has no block references.
bool IsConstant(const Expr& e);

// "distance(arm.tip, p3) + 2 mm" with each slot printed by name. Constants are printed in
// the model's canonical units (m, deg for angles).
std::string Describe(const Expr& e, std::span<const std::string> slot_names);
std::string FormatQuantity(double value, Quantity q);

// Value of the tree; a scalar is returned in x().
template <typename T>
Vector3<T> Evaluate(const Expr& e, std::span<const BlockState<T>> x) {
  switch (e.op) {
    case Expr::Op::kConstant:
      return e.constant.cast<T>();
    case Expr::Op::kPoint:
      return x[e.slot].t;
    case Expr::Op::kFeature:
      return x[e.slot].R * e.constant.cast<T>() + x[e.slot].t;
    case Expr::Op::kVector:
      return Vector3<T>(Evaluate<T>(*e.args[0], x).x(), Evaluate<T>(*e.args[1], x).x(),
                        Evaluate<T>(*e.args[2], x).x());
    case Expr::Op::kNeg:
      return -Evaluate<T>(*e.args[0], x);
    case Expr::Op::kAdd:
      return Evaluate<T>(*e.args[0], x) + Evaluate<T>(*e.args[1], x);
    case Expr::Op::kSub:
      return Evaluate<T>(*e.args[0], x) - Evaluate<T>(*e.args[1], x);
    case Expr::Op::kMul: {
      // At most one operand is a vector (checked at construction).
      const Vector3<T> a = Evaluate<T>(*e.args[0], x), b = Evaluate<T>(*e.args[1], x);
      if (e.args[0]->type.vector) return a * b.x();
      if (e.args[1]->type.vector) return b * a.x();
      return Vector3<T>(a.x() * b.x(), T(0), T(0));
    }
    case Expr::Op::kDiv: {
      const Vector3<T> a = Evaluate<T>(*e.args[0], x), b = Evaluate<T>(*e.args[1], x);
      if (e.args[0]->type.vector) return a / b.x();
      return Vector3<T>(a.x() / b.x(), T(0), T(0));
    }
    case Expr::Op::kCall: {
      Vector3<T> args[3];
      for (size_t i = 0; i < e.args.size(); ++i) args[i] = Evaluate<T>(*e.args[i], x);
      return ApplyFunction<T>(e.function, std::span<const Vector3<T>>(args, e.args.size()));
    }
  }
  return Vector3<T>::Zero();
}

}  // namespace cfuse
