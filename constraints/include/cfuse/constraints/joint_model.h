// What a joint type does, in one place (Pinocchio's joint models): the motion its variable
// gives, its residual, and its parameters in the parametric form (Lowe's joint angles) with
// their twists, ⊞ and ⊟ on the joint's state. Algorithms ask a joint's model; none switches on
// its JointType. Adding a joint type is its residual (kinds/), one JointModel here and its row
// in ModelOf().
//
// Frames: A = world_from_parent * parent_from_joint is the joint frame on the parent in the
// world, B = A * motion the same frame on the child; `axis` is in the joint frame.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/constraints/kinds/joint_frames.h"
#include "cfuse/kernel/residual.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

class JointModel {
 public:
  // A parameter of the parametric form: its name after the joint's ("" for the joint variable
  // itself, else "<joint>.<suffix>") and whether it is an angle (else a length).
  struct Parameter {
    const char* suffix;
    bool angle;
  };

  virtual ~JointModel() = default;

  // In the parametric form's order; none for a fixed joint.
  virtual const std::vector<Parameter>& Parameters() const = 0;
  int ParameterCount() const { return static_cast<int>(Parameters().size()); }

  // A scalar joint variable q (revolute, continuous, prismatic), whose Motion(q) the joint's
  // state is; the others keep their relative motion itself.
  virtual bool HasVariable() const { return false; }
  // Whether the variable is a length along the axis (prismatic) rather than an angle about it.
  bool VariableIsLength() const { return HasVariable() && !Parameters().front().angle; }
  // Motion(q) for a joint with a variable; the identity for the others.
  virtual Rigid3d Motion(const Eigen::Vector3d& /*axis*/, double /*q*/) const { return Rigid3d(); }
  // For a joint with a variable, the q whose Motion(q) `motion` is nearest: the shift along the
  // axis, or the angle about it in (-π, π]. 0 for the others.
  virtual double Variable(const Eigen::Vector3d& /*axis*/, const Rigid3d& /*motion*/) const {
    return 0;
  }

  // For a joint without a variable: its motion nearest to `relative`, the child's joint frame
  // in the parent's (the identity for the others).
  virtual Rigid3d Nearest(const Eigen::Vector3d& /*axis*/, const Rigid3d& /*relative*/) const {
    return Rigid3d();
  }

  // The world twists [ω; v] of its parameters, written to columns `first`.. of the 6 x n `T`:
  // a point moved by parameter i moves by ω_i × p + v_i.
  virtual void Twists(const Eigen::Vector3d& axis, const Rigid3d& A, const Rigid3d& B,
                      Eigen::MatrixXd* T, int first) const = 0;
  // The joint's state (`q` for a joint with a variable, else `motion`) moved by its parameters'
  // step d (ParameterCount() values).
  virtual void Retract(const Eigen::Vector3d& axis, const double* d, double* q,
                       Rigid3d* motion) const = 0;
  // d with to = from ⊞ d, to first order for the rotations.
  virtual void Difference(const Eigen::Vector3d& axis, double q_from, double q_to,
                          const Rigid3d& from, const Rigid3d& to, double* d) const = 0;

  // Whether the joint frames, the child's turned by `relative` from the parent's, are near a
  // configuration of the joint (within about a quarter turn of its allowed rotations): a part
  // turned onto itself upside down about its spine is none.
  virtual bool NearConfiguration(const Eigen::Vector3d& axis,
                                 const Eigen::Quaterniond& relative) const = 0;

  // Its residual over the slots (parent pose, child pose); null for a floating joint, which
  // constrains nothing.
  virtual std::shared_ptr<const ResidualFunction> MakeResidual(const JointGeometry& geometry,
                                                               const std::string& name) const = 0;
};

const JointModel& ModelOf(JointType type);

}  // namespace cfuse
