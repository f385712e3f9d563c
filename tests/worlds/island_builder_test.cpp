// IslandBuilder and IslandItems (worlds/src/island_builder.h): islands are
// the connected components of the joins, numbered by their smallest node
// whatever the order of the joins, nodes ascending inside each; items
// grouped by island and ordered by key; edges with an end outside the graph
// join nothing. Checked against a brute-force labelling on random graphs.
#include <algorithm>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "island_builder.h"

namespace soda {
namespace {

// Every island as its sorted node list, islands in order of their number.
std::vector<std::vector<int>> islands_of(const IslandBuilder& b) {
  std::vector<std::vector<int>> out;
  for (int k = 0; k < b.island_count(); ++k)
    out.emplace_back(b.order().begin() + b.begin(k), b.order().begin() + b.begin(k + 1));
  return out;
}

// Components by flooding from each unlabelled node in ascending order: the
// reference numbering (smallest node first).
std::vector<std::vector<int>> reference(int n, const std::vector<std::pair<int, int>>& edges) {
  std::vector<std::vector<int>> adjacent(static_cast<std::size_t>(n));
  for (auto [a, b] : edges)
    if (a >= 0 && b >= 0) adjacent[a].push_back(b), adjacent[b].push_back(a);
  std::vector<int> label(static_cast<std::size_t>(n), -1);
  std::vector<std::vector<int>> out;
  for (int s = 0; s < n; ++s) {
    if (label[s] >= 0) continue;
    const int k = static_cast<int>(out.size());
    out.emplace_back();
    std::vector<int> stack{s};
    label[s] = k;
    while (!stack.empty()) {
      const int v = stack.back();
      stack.pop_back();
      out[k].push_back(v);
      for (int w : adjacent[v])
        if (label[w] < 0) label[w] = k, stack.push_back(w);
    }
    std::sort(out[k].begin(), out[k].end());
  }
  return out;
}

TEST(IslandBuilder, ChainsAndLoneNodes) {
  IslandBuilder b;
  b.reset(6);
  b.join(4, 2);
  b.join(5, 4);
  b.join(IslandBuilder::kNoNode, 1);  // a static end: no join
  b.join(3, IslandBuilder::kNoNode);
  b.finish();
  ASSERT_EQ(b.island_count(), 4);
  EXPECT_EQ(islands_of(b), (std::vector<std::vector<int>>{{0}, {1}, {2, 4, 5}, {3}}));
  EXPECT_EQ(b.island_of(5), 2);
  EXPECT_EQ(b.island_of(3), 3);
  EXPECT_EQ(b.size(2), 3);
}

TEST(IslandBuilder, NoNodes) {
  IslandBuilder b;
  b.reset(0);
  b.finish();
  EXPECT_EQ(b.island_count(), 0);
  EXPECT_TRUE(b.order().empty());
}

TEST(IslandBuilder, SameIslandsForAnyJoinOrderAsFlooding) {
  std::mt19937 rng(7);
  IslandBuilder b;  // reused: reset() forgets the last graph
  for (int round = 0; round < 200; ++round) {
    const int n = 1 + static_cast<int>(rng() % 60);
    std::vector<std::pair<int, int>> edges;
    const int m = static_cast<int>(rng() % (2 * n));
    for (int i = 0; i < m; ++i) {
      const int a = static_cast<int>(rng() % (n + 1)) - 1;  // -1: kNoNode
      const int c = static_cast<int>(rng() % n);
      edges.emplace_back(a, c);
    }
    const std::vector<std::vector<int>> want = reference(n, edges);
    for (int order = 0; order < 3; ++order) {
      std::shuffle(edges.begin(), edges.end(), rng);
      b.reset(n);
      for (auto [x, y] : edges) (order % 2 ? b.join(y, x) : b.join(x, y));
      b.finish();
      ASSERT_EQ(islands_of(b), want) << "round " << round << ", order " << order;
      for (int k = 0; k < b.island_count(); ++k)
        for (int v : want[static_cast<std::size_t>(k)]) ASSERT_EQ(b.island_of(v), k);
    }
  }
}

TEST(IslandItems, GroupedByIslandThenKey) {
  IslandItems<int> items;
  items.clear();
  items.add(2, {7, 9}, 100);
  items.add(0, {3, 4}, 101);
  items.add(2, {1, 9}, 102);
  items.add(0, {1, 4}, 103);
  items.finish(4);
  ASSERT_EQ(items.size(), 4u);
  EXPECT_EQ(items.values(), (std::vector<int>{103, 101, 102, 100}));
  EXPECT_EQ(items.count(0), 2);
  EXPECT_EQ(items.count(1), 0);
  EXPECT_EQ(items.values(1), nullptr);
  EXPECT_EQ(items.count(2), 2);
  EXPECT_EQ(items.count(3), 0);
  EXPECT_EQ(*items.values(2), 102);
  EXPECT_EQ(items[static_cast<std::size_t>(items.begin(2))].key, (std::pair<BodyId, BodyId>{1, 9}));
  EXPECT_EQ(items.first_duplicate(), -1);
}

TEST(IslandItems, FindsADuplicateKeyInOneIslandOnly) {
  IslandItems<int> items;
  items.add(0, {1, 2}, 1);
  items.add(1, {1, 2}, 2);  // another island: not a duplicate
  items.finish(2);
  EXPECT_EQ(items.first_duplicate(), -1);
  items.add(1, {1, 2}, 3);
  items.finish(2);
  EXPECT_EQ(items.first_duplicate(), 2);
}

TEST(IslandItems, OrderDoesNotDependOnInsertionOrder) {
  std::mt19937 rng(3);
  std::vector<std::pair<int, std::pair<BodyId, BodyId>>> all;
  for (int i = 0; i < 300; ++i)
    all.push_back({static_cast<int>(rng() % 10), {static_cast<BodyId>(i % 37), static_cast<BodyId>(i)}});
  std::vector<int> first;
  for (int round = 0; round < 4; ++round) {
    std::shuffle(all.begin(), all.end(), rng);
    IslandItems<int> items;
    for (const auto& [island, key] : all) items.add(island, key, static_cast<int>(key.second));
    items.finish(10);
    if (round == 0) first = items.values();
    EXPECT_EQ(items.values(), first);
  }
}

}  // namespace
}  // namespace soda
