// rcb: weighted bisection, relabelling to the current owners, and when a
// repartition is taken; the assignment it relabels with.
#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "assignment.h"
#include "loadbalance/synthetic_load.h"
#include "rcb_policy.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

constexpr CostCoefficients kTruth{20e-6, 0.3e-6, 0.6e-6, 1.2e-6};

TEST(Assignment, FindsTheLargestTotal) {
  const std::vector<std::vector<double>> w{{1, 9, 0}, {8, 7, 0}, {0, 0, 1}};
  EXPECT_EQ(detail::max_weight_assignment(w), (std::vector<int>{1, 0, 2}));
  const std::vector<std::vector<double>> ties{{1, 1}, {1, 1}};
  EXPECT_EQ(detail::max_weight_assignment(ties), detail::max_weight_assignment(ties));
  EXPECT_TRUE(detail::max_weight_assignment({}).empty());
}

TEST(Bisect, EqualWeightsGiveEqualBoxes) {
  const CellBox box{{0, 0, 0}, {7, 0, 3}};
  const std::vector<int> parts = detail::bisect(box, std::vector<double>(32, 1.0), 4);
  std::vector<int> count(4, 0);
  for (int p : parts) ++count[static_cast<std::size_t>(p)];
  EXPECT_EQ(count, (std::vector<int>{8, 8, 8, 8}));
  EXPECT_EQ(parts[box.index({0, 0, 0})], 0);  // the longest axis, x, first
  EXPECT_EQ(parts[box.index({7, 0, 3})], 3);
}

// A 3 x 3 region for 9 worlds cannot be halved with floor(9/2) worlds on
// one side of any boundary; the counts shift and every world gets a cell.
TEST(Bisect, EveryWorldGetsACellWhenTheCountsMustShift) {
  const CellBox box{{0, 0, 0}, {2, 0, 2}};
  for (int k = 2; k <= 9; ++k) {
    const std::vector<int> parts = detail::bisect(box, std::vector<double>(9, 1.0), k);
    std::vector<int> count(static_cast<std::size_t>(k), 0);
    for (int p : parts) ++count[static_cast<std::size_t>(p)];
    for (int w = 0; w < k; ++w) EXPECT_GE(count[static_cast<std::size_t>(w)], 1) << "k " << k << " world " << w;
  }
}

TEST(Rcb, RepartitionsByCostAndKeepsOwnersWhereItCan) {
  BalanceOptions options;
  options.policy = "rcb";
  const CellBox box{{0, 0, 0}, {15, 0, 3}};
  const TerritoryMap map = test::make_map(box, 4, [](const CellCoord& c) { return c.x / 4; });
  test::CellBodies bodies;
  for (int x = 8; x < 16; ++x)
    for (int z = 0; z < 4; ++z) bodies[{x, 0, z}] = 30;  // all load in worlds 2 and 3
  auto policy = make_balance_policy(options);
  EXPECT_STREQ(policy->name(), "rcb");
  const LoadView view = test::make_view(map, bodies, kTruth);
  const std::vector<CellMove> moves = policy->decide(view);
  ASSERT_FALSE(moves.empty());
  const TerritoryMap after = test::apply(map, moves);
  const double before_imbalance = test::busy_imbalance(view);
  const double after_imbalance = test::busy_imbalance(test::make_view(after, bodies, kTruth));
  EXPECT_GT(before_imbalance, 1.9);
  EXPECT_LT(after_imbalance, 1.1);
  for (WorldId w = 0; w < 4; ++w) {
    EXPECT_GE(after.cell_count(w), 1);
    EXPECT_EQ(territory_pieces(after, w), 1);
  }
  // Relabelled to overlap: fewer bodies change hands than with the parts
  // numbered in bisection order.
  const std::vector<int> parts = detail::bisect(box, std::vector<double>(64, 1.0), 4);
  std::int64_t relabelled = 0, numbered = 0;
  for (const auto& [c, n] : bodies) {
    relabelled += after.owner(c) != map.owner(c) ? n : 0;
  }
  std::vector<double> weights(64);
  for (std::size_t i = 0; i < 64; ++i) {
    const auto it = bodies.find(box.cell_at(i));
    weights[i] = it == bodies.end() ? 0.01 : 1.0;
  }
  const std::vector<int> by_number = detail::bisect(box, weights, 4);
  for (const auto& [c, n] : bodies) numbered += by_number[box.index(c)] != map.owner(c) ? n : 0;
  EXPECT_LT(relabelled, numbered);
  (void)parts;
  // Balanced now: measuring the new map moves nothing more.
  auto again = make_balance_policy(options);
  EXPECT_TRUE(again->decide(test::make_view(after, bodies, kTruth)).empty());
}

TEST(Rcb, NothingMovesWithoutAnOverloadedWorld) {
  BalanceOptions options;
  options.policy = "rcb";
  const CellBox box{{0, 0, 0}, {7, 0, 3}};
  const TerritoryMap map = test::make_map(box, 2, [](const CellCoord& c) { return c.x < 4 ? 0 : 1; });
  test::CellBodies bodies;
  for (std::size_t i = 0; i < 32; ++i) bodies[box.cell_at(i)] = box.cell_at(i).x == 0 ? 20 : 10;  // 1.08
  EXPECT_TRUE(make_balance_policy(options)->decide(test::make_view(map, bodies, kTruth)).empty());
}

}  // namespace
}  // namespace soda
