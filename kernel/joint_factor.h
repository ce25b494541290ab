// Several constraints on overlapping blocks fused as one factor, so that their local
// iterations solve all of them together.
//
// Fused one at a time, each constraint is linearised and then frozen in the covariance; where
// two of them are degenerate together at first order (a point on a sphere about one
// neighbour and on a line through another that is tangent to that sphere: a hinge's second
// side point held by a distance and a parallel axis), the second one's Gauss-Newton iterations
// run along the frozen tangent and diverge. Together, the iterations see both curvatures and
// converge as a batch solve would.
#pragma once

#include <algorithm>
#include <array>
#include <memory>
#include <vector>

#include "kernel/check.h"
#include "kernel/factor.h"
#include "kernel/residual.h"

namespace cfuse {

class JointResidual : public AutoDiffResidual<JointResidual> {
 public:
  static constexpr int kMaxPartSlots = 8;

  struct Part {
    std::shared_ptr<const ResidualFunction> residual;
    std::vector<int> slots;  // per slot of the part: its slot in the joint residual
  };

  JointResidual(std::vector<Part> parts, std::vector<BlockKind> kinds)
      : AutoDiffResidual(TotalDimension(parts), std::move(kinds)), parts_(std::move(parts)) {
    for (const Part& p : parts_) {
      CFUSE_CHECK(p.slots.size() <= kMaxPartSlots);
      for (size_t i = 0; i < p.slots.size(); ++i) {
        CFUSE_CHECK(slot_kinds().at(p.slots[i]) == p.residual->slot_kinds()[i]);
      }
    }
  }

  bool is_linear() const override {
    return std::all_of(parts_.begin(), parts_.end(),
                       [](const Part& p) { return p.residual->is_linear(); });
  }

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    std::array<BlockState<T>, kMaxPartSlots> local;
    for (const Part& p : parts_) {
      for (size_t i = 0; i < p.slots.size(); ++i) local[i] = x[p.slots[i]];
      p.residual->Evaluate(std::span<const BlockState<T>>(local.data(), p.slots.size()), r);
      r += p.residual->dimension();
    }
  }

  std::string Describe(std::span<const std::string> names) const override {
    std::string s;
    for (const Part& p : parts_) {
      std::vector<std::string> own;
      for (int slot : p.slots) own.push_back(names[slot]);
      s += (s.empty() ? "" : "; ") + p.residual->Describe(own);
    }
    return s;
  }

 private:
  static int TotalDimension(const std::vector<Part>& parts) {
    int n = 0;
    for (const Part& p : parts) n += p.residual->dimension();
    return n;
  }
  std::vector<Part> parts_;
};

// One constraint factor (no noise) from several: its blocks are the union of theirs, in order
// of first appearance, and its kinds are given by `kinds` (per block id).
inline Factor JointConstraint(const std::vector<Factor>& constraints,
                              const std::vector<BlockKind>& kinds, std::string name) {
  Factor joint;
  joint.name = std::move(name);
  std::vector<JointResidual::Part> parts;
  std::vector<BlockKind> slot_kinds;
  for (const Factor& c : constraints) {
    CFUSE_CHECK(c.is_constraint());
    JointResidual::Part part{c.residual, {}};
    for (int b : c.blocks) {
      auto it = std::find(joint.blocks.begin(), joint.blocks.end(), b);
      if (it == joint.blocks.end()) {
        joint.blocks.push_back(b);
        slot_kinds.push_back(kinds.at(b));
        it = joint.blocks.end() - 1;
      }
      part.slots.push_back(static_cast<int>(it - joint.blocks.begin()));
    }
    parts.push_back(std::move(part));
  }
  joint.residual = std::make_shared<JointResidual>(std::move(parts), std::move(slot_kinds));
  return joint;
}

}  // namespace cfuse
