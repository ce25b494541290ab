// The fusion order by group growth: measurements first as given, then each constraint when the
// group its fusion forms is the smallest still possible (checked against a recount at every
// step), on a hand-worked case and on a random graph.
#include "cfuse/kernel/fusion_order.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <random>

#include "cfuse/kernel/correlation_groups.h"

namespace cfuse {
namespace {

// The order reads only a factor's blocks and whether it has noise.
Factor Measurement(std::vector<int> blocks) {
  return {nullptr, std::move(blocks), Eigen::Matrix3d::Identity(), "m"};
}
Factor Constraint(std::vector<int> blocks) { return {nullptr, std::move(blocks), {}, "c"}; }

TEST_CASE("fusion order: measurements first, then the smallest groups", "[kernel]") {
  const std::vector<Factor> factors = {
      Constraint({1, 2}),  // 0: joins the parts {0, 1} and {2, 3} once they exist
      Measurement({0}),    // 1
      Constraint({0, 1}),  // 2
      Measurement({3}),    // 3
      Constraint({2, 3}),  // 4
      Constraint({4, 5}),  // 5: a part of its own
  };
  // Each constraint would first form a group of 2: 0 goes first (given first) and makes {1, 2}.
  // Then 2 and 4 would form groups of 3, 5 still one of 2: 5. Then 2 ({0, 1, 2}), then 4 (all
  // of 0 to 3).
  CHECK(GroupGrowthOrder(factors, 6) == std::vector<int>{1, 3, 0, 5, 2, 4});
  CHECK(GroupGrowthOrder({}, 3).empty());
  CHECK(GroupGrowthOrder({Measurement({1}), Measurement({0})}, 2) == std::vector<int>{0, 1});
}

TEST_CASE("fusion order: each constraint taken forms the smallest group possible then",
          "[kernel]") {
  std::mt19937 rng(11);
  const int n = 30;
  std::uniform_int_distribution<int> block(0, n - 1), arity(1, 3);
  std::vector<Factor> factors;
  for (int k = 0; k < 60; ++k) {
    std::vector<int> blocks(arity(rng));
    for (int& b : blocks) b = block(rng);
    factors.push_back(k % 4 == 0 ? Measurement(blocks) : Constraint(blocks));
  }
  const std::vector<int> order = GroupGrowthOrder(factors, n);
  REQUIRE(order.size() == factors.size());
  std::vector<bool> done(factors.size(), false);
  size_t at = 0;
  for (size_t k = 0; k < factors.size(); k += 4) CHECK(order[at++] == static_cast<int>(k));
  for (int i : order) done[i] = true;
  CHECK(std::count(done.begin(), done.end(), true) == static_cast<long>(factors.size()));

  CorrelationGroups groups(n);
  std::vector<int> support;
  auto size = [&](int i) {
    groups.Support(factors[i].blocks, &support);
    return support.size();
  };
  std::fill(done.begin(), done.end(), false);
  for (; at < order.size(); ++at) {
    size_t smallest = n + 1;
    for (size_t i = 0; i < factors.size(); ++i) {
      if (factors[i].is_constraint() && !done[i]) smallest = std::min(smallest, size(i));
    }
    INFO("step " << at);
    CHECK(size(order[at]) == smallest);
    done[order[at]] = true;
    groups.Merge(factors[order[at]].blocks);
  }
}

}  // namespace
}  // namespace cfuse
