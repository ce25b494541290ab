// Which blocks of a Gaussian estimate can be correlated.
//
// A vague prior is diagonal, and a Kalman update only correlates the blocks its factor
// touches with the blocks already correlated with them. So the blocks fall into groups whose
// cross-covariances are exactly zero, and an update need only touch the rows and columns of
// the groups its factor reaches (its "support"). While measurements are being fused into a
// fresh prior every update is O(1); constraints then merge the groups one by one, and in a
// fusion order like Hel-Or & Werman's §6 (a new point joins a growing structure) the updates
// stay far cheaper than on the whole covariance.
#pragma once

#include <span>
#include <vector>

namespace cfuse {

class CorrelationGroups {
 public:
  CorrelationGroups() = default;
  // `num_blocks` blocks, each alone (a diagonal covariance).
  explicit CorrelationGroups(int num_blocks);

  int num_blocks() const { return static_cast<int>(parent_.size()); }
  // Puts every block in one group (a covariance with no known zero blocks).
  void MergeAll();
  // Merges the groups of `blocks` into one.
  void Merge(std::span<const int> blocks);
  // The blocks of the groups of `blocks`, in increasing id order.
  void Support(std::span<const int> blocks, std::vector<int>* out) const;

 private:
  int Root(int block) const;

  // Each group's blocks as a list threaded through `next_` (-1 ends it), with its last block and
  // size kept at its root: a merge splices two lists, and copying the groups (a state is
  // copied whole, e.g. per interpretation branch) copies four flat arrays.
  std::vector<int> parent_;
  std::vector<int> next_;
  std::vector<int> last_;  // at each root
  std::vector<int> size_;  // at each root
};

}  // namespace cfuse
