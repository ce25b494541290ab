// Several residuals on the same slots, stacked into one: the measurements of one rigid
// component fused in a single update. One 3D point (or image point) alone leaves a pose's
// rotation undetermined about it, and under a vague rotation prior the local iterations would
// wander along that freedom; three or more points together determine the pose, as the
// closed-form start that precedes them does. Fusing uncorrelated measurements together or one
// by one has the same optimum.
#pragma once

#include <memory>
#include <vector>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/residual.h"

namespace cfuse {

class StackedResidual : public AutoDiffResidual<StackedResidual> {
 public:
  explicit StackedResidual(std::vector<std::shared_ptr<const ResidualFunction>> parts)
      : AutoDiffResidual(TotalDimension(parts), parts.at(0)->slot_kinds()),
        parts_(std::move(parts)) {
    for (const auto& p : parts_) CFUSE_CHECK(p->slot_kinds() == slot_kinds());
  }

  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    for (const auto& p : parts_) {
      p->Evaluate(x, r);
      r += p->dimension();
    }
  }

  std::string Describe(std::span<const std::string> names) const override {
    std::string s;
    for (const auto& p : parts_) s += (s.empty() ? "" : "; ") + p->Describe(names);
    return s;
  }

 private:
  static int TotalDimension(const std::vector<std::shared_ptr<const ResidualFunction>>& parts) {
    int n = 0;
    for (const auto& p : parts) n += p->dimension();
    return n;
  }
  std::vector<std::shared_ptr<const ResidualFunction>> parts_;
};

}  // namespace cfuse
