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
#include <type_traits>
#include <vector>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/residual.h"

namespace cfuse {

class CombinedResidual : public AutoDiffResidual<CombinedResidual> {
 public:
  static constexpr int kMaxPartSlots = 8;

  struct Part {
    std::shared_ptr<const ResidualFunction> residual;
    std::vector<int> slots;  // per slot of the part: its slot in the joint residual
  };

  CombinedResidual(std::vector<Part> parts, std::vector<BlockKind> kinds)
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
      if constexpr (std::is_same_v<T, Jet>) {
        // A Jacobian is taken a few tangent coordinates at a time (cfuse/kernel/jet.h); a part that
        // touches none of them is evaluated in doubles, its derivatives zero: the same values,
        // at a fraction of the cost.
        if (!Seeded(p, x)) {
          EvaluatePlain(p, x, r);
          r += p.residual->dimension();
          continue;
        }
      }
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
  // Whether some input of `p` carries a derivative.
  bool Seeded(const Part& p, std::span<const BlockState<Jet>> x) const {
    for (int slot : p.slots) {
      const BlockState<Jet>& s = x[slot];
      for (int i = 0; i < 3; ++i) {
        if (!s.t[i].derivatives().isZero(0)) return true;
      }
      if (slot_kinds()[slot] == BlockKind::kPose) {
        for (int i = 0; i < 9; ++i) {
          if (!s.R(i).derivatives().isZero(0)) return true;
        }
      }
    }
    return false;
  }

  void EvaluatePlain(const Part& p, std::span<const BlockState<Jet>> x, Jet* r) const {
    std::array<BlockState<double>, kMaxPartSlots> local;
    for (size_t i = 0; i < p.slots.size(); ++i) {
      const BlockState<Jet>& s = x[p.slots[i]];
      for (int k = 0; k < 3; ++k) local[i].t[k] = s.t[k].value();
      if (slot_kinds()[p.slots[i]] == BlockKind::kPose) {
        for (int k = 0; k < 9; ++k) local[i].R(k) = s.R(k).value();
      } else {
        local[i].R.setIdentity();  // unused by points and slacks (residual.h)
      }
    }
    std::array<double, 64> values;
    std::vector<double> more;
    double* out = values.data();
    if (p.residual->dimension() > static_cast<int>(values.size())) {
      more.resize(p.residual->dimension());
      out = more.data();
    }
    p.residual->Evaluate(std::span<const BlockState<double>>(local.data(), p.slots.size()), out);
    for (int i = 0; i < p.residual->dimension(); ++i) {
      r[i].value() = out[i];
      r[i].derivatives().setZero();
    }
  }

  std::vector<Part> parts_;
};

// One constraint factor (no noise) from several: its blocks are the union of theirs, in order
// of first appearance, and its kinds are given by `kinds` (per block id).
inline Factor CombinedConstraint(const std::vector<Factor>& constraints,
                              const std::vector<BlockKind>& kinds, std::string name) {
  Factor joint;
  joint.name = std::move(name);
  std::vector<CombinedResidual::Part> parts;
  std::vector<BlockKind> slot_kinds;
  for (const Factor& c : constraints) {
    CFUSE_CHECK(c.is_constraint());
    CombinedResidual::Part part{c.residual, {}};
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
  joint.residual = std::make_shared<CombinedResidual>(std::move(parts), std::move(slot_kinds));
  return joint;
}

}  // namespace cfuse
