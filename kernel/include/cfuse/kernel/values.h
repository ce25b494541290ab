// Variable blocks and their values: the working data of the constraint graph.
//
// The state of a model is a list of blocks (Hel-Or & Werman's T vector, §2 and §5):
//   - kPoint: a single-point component's position in the world, R^3          (tangent dim 3)
//   - kPose:  a rigid component's pose world_from_component on SE(3)         (tangent dim 6)
//   - kSlack: the slack λ of an inequality g(x) - λ² = 0 (§5.1), a scalar    (tangent dim 1)
//
// The tangent (error-state) parametrisation of a pose is the product SO(3) x R^3 chart with
// the rotation perturbed on the right and the translation in the world:
//   R <- R * Exp(δθ),   t <- t + δt,        δ = [δθ; δt] (radians, metres).
// It is a valid local chart of SE(3); we prefer it to the SE(3) exponential because the
// translation block of a covariance in it is directly the covariance of the component's
// position in the world, which is what users read.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cfuse/kernel/rigid3.h"

namespace cfuse {

enum class BlockKind { kPoint, kPose, kSlack };

constexpr int TangentDim(BlockKind kind) {
  return kind == BlockKind::kPoint ? 3 : kind == BlockKind::kPose ? 6 : 1;
}

struct Block {
  BlockKind kind = BlockKind::kPoint;
  int index = 0;           // index into the Values array of its kind
  int tangent_offset = 0;  // offset of its tangent coordinates in the state vector
  std::string name;        // the component's name, or "<constraint>.slack"
};

// A value for every block of a graph, stored by kind and indexed by Block::index.
struct Values {
  std::vector<Rigid3d> poses;           // world_from_component
  std::vector<Eigen::Vector3d> points;  // position in the world
  std::vector<double> slacks;
};

// Contract: every block's index lies inside the array of its kind (InternalError if not).
void CheckValuesFit(const std::vector<Block>& blocks, const Values& values);

// One block: values <- values ⊞ delta, delta of TangentDim(b.kind) numbers.
void RetractBlock(const Block& b, const double* delta, Values* values);
// The TangentDim(b.kind) numbers δ with to = from ⊞ δ for block b.
void LocalCoordinatesOfBlock(const Block& b, const Values& from, const Values& to, double* delta);

// values <- values ⊞ delta, delta of size `tangent dimension` laid out by Block::tangent_offset.
void Retract(const std::vector<Block>& blocks, const Eigen::VectorXd& delta, Values* values);

// The delta with to = from ⊞ delta (rotations by the logarithm, angle in [0, π]).
Eigen::VectorXd LocalCoordinates(const std::vector<Block>& blocks, const Values& from,
                                 const Values& to);

}  // namespace cfuse
