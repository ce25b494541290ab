#include "cfuse/kernel/correlation_groups.h"

#include <algorithm>
#include <numeric>

#include "cfuse/kernel/check.h"

namespace cfuse {

CorrelationGroups::CorrelationGroups(int num_blocks) : parent_(num_blocks), members_(num_blocks) {
  std::iota(parent_.begin(), parent_.end(), 0);
  for (int b = 0; b < num_blocks; ++b) members_[b] = {b};
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
    if (members_[other].size() > members_[root].size()) std::swap(root, other);
    parent_[other] = root;
    members_[root].insert(members_[root].end(), members_[other].begin(), members_[other].end());
    members_[other].clear();
    members_[other].shrink_to_fit();
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
    out->insert(out->end(), members_[r].begin(), members_[r].end());
  }
  std::sort(out->begin(), out->end());
}

}  // namespace cfuse
