#include "cfuse/kernel/fusion_order.h"

#include <queue>

#include "cfuse/kernel/correlation_groups.h"

namespace cfuse {

std::vector<int> GroupGrowthOrder(const std::vector<Factor>& factors, int num_blocks) {
  std::vector<int> order;
  order.reserve(factors.size());
  for (size_t i = 0; i < factors.size(); ++i) {
    if (!factors[i].is_constraint()) order.push_back(static_cast<int>(i));
  }
  // Measurements alone correlate nothing across blocks (each touches one component), so the
  // groups start as singletons. A constraint's merged size only grows as others are fused, so
  // a stale key is a lower bound: pop the smallest, recompute, and take it if it is still no
  // larger than the next key (lazy greedy).
  CorrelationGroups groups(num_blocks);
  using Entry = std::pair<long, int>;  // (merged size, factor index): smallest first
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  std::vector<int> support;
  auto merged_size = [&](int i) {
    groups.Support(factors[i].blocks, &support);
    return static_cast<long>(support.size());
  };
  for (size_t i = 0; i < factors.size(); ++i) {
    if (factors[i].is_constraint())
      queue.push({merged_size(static_cast<int>(i)), static_cast<int>(i)});
  }
  while (!queue.empty()) {
    const auto [key, i] = queue.top();
    queue.pop();
    const long size = merged_size(i);
    if (size > key && !queue.empty() && size > queue.top().first) {
      queue.push({size, i});
      continue;
    }
    order.push_back(i);
    groups.Merge(factors[i].blocks);
  }
  return order;
}

}  // namespace cfuse
