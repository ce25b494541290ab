// An order in which to fuse constraints cheaply when the correspondences are known.
//
// A Kalman update costs the square of its support: the rows and columns of every block
// correlated with the factor's blocks (correlation_groups.h). Fusing a constraint merges the
// groups it touches, so the order decides how fast the groups grow. Fusing first the
// constraints whose groups are smallest (the parts of a model: a lamp's base, its shade)
// and only then those that join the parts keeps most updates small. For linear factors the
// order does not change the result; for nonlinear ones the passes of FuseSequence converge to
// the same solution whatever the order.
//
// (The fusion order of Hel-Or & Werman §6, which interleaves matching with constraints, is
// the interpretation scheduler's business, interp/.)
#pragma once

#include <vector>

#include "cfuse/kernel/factor.h"

namespace cfuse {

// The indices of `factors` in fusion order: the measurements first, in their given order, then
// the constraints greedily by the size (in blocks) of the group their fusion would form, ties
// by their given order. O(C log C) heap operations for C constraints, plus union-find work.
std::vector<int> GroupGrowthOrder(const std::vector<Factor>& factors, int num_blocks);

}  // namespace cfuse
