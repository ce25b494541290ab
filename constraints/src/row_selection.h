// A constraint's independent rows: the residual of another with some of its rows left out.
//
// A relation written between parts that joints already tie can repeat some of their
// conditions: a planar four-bar closed by `coupler.end == rocker.pin` has three rows, of which
// the three parallel revolute joints already imply one (the pin's height along their common
// axis). Fused as a zero-variance measurement, a repeated row makes the update singular, and an
// image solve then fails or runs away. The model builder keeps each constraint's rows that add
// rank at the nominal geometry, in graph order (cfuse/constraints/dof.h), and wraps the
// constraint's residual in this class; `cfuse check` still names the rows left out.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "cfuse/kernel/residual.h"

namespace cfuse {

class RowSelection : public ResidualFunction {
 public:
  RowSelection(std::shared_ptr<const ResidualFunction> inner, std::vector<int> rows)
      : ResidualFunction(static_cast<int>(rows.size()), inner->slot_kinds()),
        inner_(std::move(inner)),
        rows_(std::move(rows)) {}

  bool is_linear() const override { return inner_->is_linear(); }

  void Evaluate(std::span<const BlockState<double>> x, double* residual) const override {
    Select(x, residual);
  }
  void Evaluate(std::span<const BlockState<Jet>> x, Jet* residual) const override {
    Select(x, residual);
  }

  // The relation as written: messages name what the user wrote.
  std::string Describe(std::span<const std::string> slot_names) const override {
    return inner_->Describe(slot_names);
  }

  const ResidualFunction& inner() const { return *inner_; }
  const std::vector<int>& rows() const { return rows_; }

 private:
  template <typename T>
  void Select(std::span<const BlockState<T>> x, T* residual) const {
    std::vector<T> all(static_cast<size_t>(inner_->dimension()));
    inner_->Evaluate(x, all.data());
    for (size_t i = 0; i < rows_.size(); ++i) residual[i] = all[static_cast<size_t>(rows_[i])];
  }

  std::shared_ptr<const ResidualFunction> inner_;
  std::vector<int> rows_;
};

}  // namespace cfuse
