// Which blocks may be correlated: union by size against a brute-force labelling, the support of
// a factor's blocks (sorted, each group once), and the contract on block ids.
#include "cfuse/kernel/correlation_groups.h"

#include <catch2/catch.hpp>
#include <random>
#include <vector>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

std::vector<int> SupportOf(const CorrelationGroups& groups, std::vector<int> blocks) {
  std::vector<int> out = {-1};  // overwritten: Support clears what it is given
  groups.Support(blocks, &out);
  return out;
}

TEST_CASE("correlation groups: blocks start alone and merge by groups", "[kernel]") {
  CorrelationGroups groups(6);
  CHECK(groups.num_blocks() == 6);
  CHECK(SupportOf(groups, {4, 1}) == std::vector<int>{1, 4});
  CHECK(SupportOf(groups, {}).empty());
  groups.Merge(std::vector<int>{1, 3});
  groups.Merge(std::vector<int>{5, 4});
  groups.Merge(std::vector<int>{2});  // one block: nothing to merge
  groups.Merge(std::vector<int>{});
  CHECK(SupportOf(groups, {3}) == std::vector<int>{1, 3});
  CHECK(SupportOf(groups, {2}) == std::vector<int>{2});
  // Each group once, however many of its blocks are named.
  CHECK(SupportOf(groups, {4, 3, 5, 1, 3}) == std::vector<int>{1, 3, 4, 5});
  groups.Merge(std::vector<int>{3, 5});
  CHECK(SupportOf(groups, {1}) == std::vector<int>{1, 3, 4, 5});
  groups.MergeAll();
  CHECK(SupportOf(groups, {0}) == std::vector<int>{0, 1, 2, 3, 4, 5});

  CorrelationGroups none;
  CHECK(none.num_blocks() == 0);
  none.MergeAll();
  CHECK(SupportOf(none, {}).empty());
}

TEST_CASE("correlation groups: random merges agree with a brute-force labelling", "[kernel]") {
  std::mt19937 rng(7);
  const int n = 40;
  CorrelationGroups groups(n);
  std::vector<int> label(n);
  for (int b = 0; b < n; ++b) label[b] = b;
  std::uniform_int_distribution<int> block(0, n - 1), size(1, 3);
  for (int step = 0; step < 30; ++step) {
    std::vector<int> merged(size(rng));
    for (int& b : merged) b = block(rng);
    groups.Merge(merged);
    for (int b : merged) {
      const int old = label[b], now = label[merged[0]];
      for (int& l : label) {
        if (l == old) l = now;
      }
    }
    const std::vector<int> query = {block(rng), block(rng)};
    std::vector<int> expected;
    for (int b = 0; b < n; ++b) {
      if (label[b] == label[query[0]] || label[b] == label[query[1]]) expected.push_back(b);
    }
    INFO("step " << step);
    CHECK(SupportOf(groups, query) == expected);
  }
}

TEST_CASE("correlation groups: a block id out of range breaks the contract", "[kernel]") {
  CorrelationGroups groups(3);
  std::vector<int> out;
  CHECK_THROWS_AS(groups.Support(std::vector<int>{3}, &out), InternalError);
  CHECK_THROWS_AS(groups.Support(std::vector<int>{-1}, &out), InternalError);
  CHECK_THROWS_AS(groups.Merge(std::vector<int>{0, 7}), InternalError);
}

}  // namespace
}  // namespace cfuse
