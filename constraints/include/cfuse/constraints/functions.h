// The built-in functions of the constraint language, templated on the scalar.
//
//   distance(a, b)        |a - b|                          points -> length
//   angle(a, b, c)        angle at b between a-b and c-b   points -> angle in [0, π]
//   angle_between(u, v)   angle between two vectors        vectors -> angle in [0, π]
//   dot(u, v)             u · v                            quantities multiply
//   cross(u, v)           u × v                            quantities multiply
//   norm(u)               |u|
//
// Angles use atan2(|u × v|, u · v) rather than acos(û · v̂): it is accurate over the whole
// range, where acos loses half the digits near 0 and π. Like every unsigned angle it is not
// differentiable at exactly 0 or π, nor are distance and norm at zero length; the model
// builder refuses constraints whose Jacobian is not finite at the nominal geometry.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <optional>
#include <span>
#include <string>

#include "cfuse/kernel/jet.h"
#include "cfuse/kernel/so3.h"

namespace cfuse {

enum class Function { kDistance, kAngle, kAngleBetween, kDot, kCross, kNorm };

// Physical dimension m^length · rad^angle. Scalars without unit have both zero.
struct Quantity {
  int length = 0;
  int angle = 0;
  bool operator==(const Quantity&) const = default;
  Quantity operator*(const Quantity& o) const { return {length + o.length, angle + o.angle}; }
  Quantity operator/(const Quantity& o) const { return {length - o.length, angle - o.angle}; }
  // "m", "m^2", "rad", "m/rad", "1" (dimensionless).
  std::string ToString() const;
  static Quantity Length() { return {1, 0}; }
  static Quantity Angle() { return {0, 1}; }
};

struct ExprType {
  bool vector = false;  // a 3-vector, otherwise a scalar
  Quantity quantity;
  bool operator==(const ExprType&) const = default;
  std::string ToString() const;  // e.g. "scalar [m]", "vector [m]"
};

struct FunctionInfo {
  Function id;
  const char* name;
  int arity;
  const char* signature;  // for messages, e.g. "angle(a, b, c): three points, the angle at b"
};

// nullptr if no built-in function has that name.
const FunctionInfo* FindFunction(std::string_view name);
const FunctionInfo& GetFunctionInfo(Function f);

// The result type of f applied to arguments of these types, or nullopt with *why set.
std::optional<ExprType> FunctionResultType(Function f, std::span<const ExprType> args,
                                           std::string* why);

template <typename T>
T AngleBetween(const Vector3<T>& u, const Vector3<T>& v) {
  return Atan2(u.cross(v).norm(), u.dot(v));
}

// Applies f; scalar arguments and results are carried in x().
template <typename T>
Vector3<T> ApplyFunction(Function f, std::span<const Vector3<T>> a) {
  Vector3<T> out = Vector3<T>::Zero();
  switch (f) {
    case Function::kDistance:
      out.x() = (a[0] - a[1]).norm();
      break;
    case Function::kAngle:
      out.x() = AngleBetween<T>(a[0] - a[1], a[2] - a[1]);
      break;
    case Function::kAngleBetween:
      out.x() = AngleBetween<T>(a[0], a[1]);
      break;
    case Function::kDot:
      out.x() = a[0].dot(a[1]);
      break;
    case Function::kCross:
      out = a[0].cross(a[1]);
      break;
    case Function::kNorm:
      out.x() = a[0].norm();
      break;
  }
  return out;
}

}  // namespace cfuse
