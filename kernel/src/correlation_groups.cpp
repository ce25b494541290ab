#include "cfuse/kernel/correlation_groups.h"

#include <algorithm>
#include <numeric>

#include "cfuse/kernel/check.h"

namespace cfuse {

CorrelationGroups::CorrelationGroups(int num_blocks)
    : parent_(num_blocks), next_(num_blocks, -1), last_(num_blocks), size_(num_blocks, 1) {
  std::iota(parent_.begin(), parent_.end(), 0);
  std::iota(last_.begin(), last_.end(), 0);
}

int CorrelationGroups::Root(int block) const {
  CFUSE_CHECK(block >= 0 && block < num_blocks());
  // Union by size keeps the trees O(log n) deep, so no path compression (and no mutation in
  // a const query) is needed.
  while (parent_[block] != block) block = parent_[block];
  return block;
}

void CorrelationGroups::MergeAll() {
  std::vector<int> all(parent_.size());
  std::iota(all.begin(), all.end(), 0);
  Merge(all);
}

void CorrelationGroups::Merge(std::span<const int> blocks) {
  if (blocks.empty()) return;
  int root = Root(blocks[0]);
  for (int b : blocks.subspan(1)) {
    int other = Root(b);
    if (other == root) continue;
    if (size_[other] > size_[root]) std::swap(root, other);
    parent_[other] = root;
    next_[last_[root]] = other;  // a root heads its own list
    last_[root] = last_[other];
    size_[root] += size_[other];
  }
}

void CorrelationGroups::Support(std::span<const int> blocks, std::vector<int>* out) const {
  out->clear();
  // Each root once; a factor touches few blocks, so a linear scan beats a set.
  thread_local std::vector<int> roots;
  roots.clear();
  for (int b : blocks) {
    const int r = Root(b);
    if (std::find(roots.begin(), roots.end(), r) != roots.end()) continue;
    roots.push_back(r);
    for (int m = r; m >= 0; m = next_[m]) out->push_back(m);
  }
  std::sort(out->begin(), out->end());
}

}  // namespace cfuse
