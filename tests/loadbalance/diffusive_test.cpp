// diffusive: cession between neighbours on synthetic loads — it evens out
// estimated loads within the cell cap, keeps territories connected, stops
// once balanced, ignores a spike, and relocates a starving world (famine).
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <vector>

#include "cession_planner.h"
#include "diffusive_policy.h"
#include "loadbalance/synthetic_load.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

constexpr CostCoefficients kTruth{20e-6, 0.3e-6, 0.6e-6, 1.2e-6};

struct CessionRun {
  TerritoryMap map;
  test::CellBodies bodies;
  std::unique_ptr<BalancePolicy> policy;
  std::vector<std::vector<CellMove>> history;
  int bestowals = 0;  // worlds that gave all their cells (famine)
  int max_given_loaded = 0;  // most loaded cells one world gave in one step

  // One balance step: measure, decide, check the rules every decision
  // keeps, apply.
  double step(std::int64_t at, const BalanceOptions& options) {
    const LoadView view = test::make_view(map, bodies, kTruth, at);
    const std::vector<CellMove> moves = policy->decide(view);
    std::map<WorldId, int> given, given_loaded;
    for (const CellMove& m : moves) {
      ++given[m.from];
      if (bodies.count(m.cell) && bodies.at(m.cell) > 0) ++given_loaded[m.from];
    }
    // The cap holds for every world but one bestowing all its cells
    // (famine); it counts cells holding bodies (empty ones follow freely),
    // and grows with a world's excess up to kMaxCapFactor times the option.
    for (const auto& [w, n] : given) {
      if (n == map.cell_count(w)) ++bestowals;
      else EXPECT_LE(given_loaded[w], detail::kMaxCapFactor * options.max_cells_per_move) << "world " << w << " at " << at;
      max_given_loaded = std::max(max_given_loaded, given_loaded[w]);
    }
    map = test::apply(map, moves);
    for (WorldId w = 0; w < map.world_count(); ++w) {
      EXPECT_GE(map.cell_count(w), 1) << "world " << w << " at " << at;
      EXPECT_EQ(territory_pieces(map, w), 1) << "world " << w << " at " << at;
    }
    history.push_back(moves);
    return test::busy_imbalance(test::make_view(map, bodies, kTruth, at));
  }
};

// Two slabs of 4 x 1 x 4 cells; world 0's cells hold 50 bodies each, world
// 1's 5: busy 0.97 ms against 0.13 ms (imbalance 1.76).
CessionRun two_slabs(const BalanceOptions& options) {
  const CellBox box{{0, 0, 0}, {7, 0, 3}};
  CessionRun run{test::make_map(box, 2, [](const CellCoord& c) { return c.x < 4 ? 0 : 1; }), {},
          make_balance_policy(options), {}, 0};
  for (std::size_t i = 0; i < static_cast<std::size_t>(box.count()); ++i) {
    const CellCoord c = box.cell_at(i);
    run.bodies[c] = c.x < 4 ? 50 : 5;
  }
  return run;
}

TEST(Diffusive, EvensOutTheLoadWithinTheCapAndThenStops) {
  BalanceOptions options;
  options.policy = "diffusive";
  CessionRun run = two_slabs(options);
  EXPECT_STREQ(run.policy->name(), "diffusive");
  EXPECT_GT(test::busy_imbalance(test::make_view(run.map, run.bodies, kTruth)), 1.7);
  double imbalance = 0;
  for (int s = 0; s < 12; ++s) imbalance = run.step(20 * (s + 1), options);
  EXPECT_LT(imbalance, options.overload) << "balanced to the threshold";
  // Once balanced, nothing moves (no back and forth).
  int late_moves = 0;
  for (int s = 12; s < 24; ++s) {
    run.step(20 * (s + 1), options);
    late_moves += static_cast<int>(run.history.back().size());
  }
  EXPECT_EQ(late_moves, 0);
  // Every move went from the loaded world 0 to world 1: never back.
  for (const auto& moves : run.history)
    for (const CellMove& m : moves) EXPECT_EQ(m.from, 0);
}

TEST(Diffusive, GivesLoadedCellsNotJustCells) {
  // World 0 has its load in the column next to the border (x = 3) only:
  // the first cells given are loaded ones.
  BalanceOptions options;
  options.policy = "diffusive";
  CessionRun run = two_slabs(options);
  for (auto& [c, n] : run.bodies) n = c.x == 3 ? 200 : (c.x < 4 ? 0 : 5);
  const double before = test::busy_imbalance(test::make_view(run.map, run.bodies, kTruth));
  const double after = run.step(20, options);
  ASSERT_FALSE(run.history[0].empty());
  // Loaded cells only; the empty cells behind them (x = 2, bordering no
  // loaded cell of world 0 once x = 3 is given) follow them.
  int loaded = 0;
  for (const CellMove& m : run.history[0]) {
    if (m.cell.x == 3) ++loaded;
    else EXPECT_EQ(m.cell.x, 2);
  }
  EXPECT_GT(loaded, 0);
  for (const CellMove& m : run.history[0]) {
    if (m.cell.x != 2) continue;
    EXPECT_NE(std::find(run.history[0].begin(), run.history[0].end(), CellMove{{3, 0, m.cell.z}, 0, 1}),
              run.history[0].end())
        << "the empty cell (2, 0, " << m.cell.z << ") follows a loaded one";
  }
  EXPECT_LT(after, before);
}

// The cap on loaded cells given grows with the giver's excess (§3.3.2: the
// larger the divergence, the faster it is rebalanced): world 0 at 1.76 x
// the mean gives more than max_cells_per_move loaded cells at once, and
// balances in fewer steps than at the plain cap would allow.
TEST(Diffusive, ALargeExcessWidensTheCap) {
  BalanceOptions options;
  options.policy = "diffusive";
  options.max_cells_per_move = 1;
  CessionRun run = two_slabs(options);
  run.step(20, options);
  EXPECT_GT(run.max_given_loaded, options.max_cells_per_move);
  double imbalance = 0;
  for (int s = 1; s < 6; ++s) imbalance = run.step(20 * (s + 1), options);
  EXPECT_LT(imbalance, options.overload) << "balanced to the threshold in 6 steps at 1 cell per move";
}

TEST(Diffusive, ASingleSpikeMovesNothing) {
  BalanceOptions options;
  options.policy = "diffusive";
  CessionRun run = two_slabs(options);
  for (auto& [c, n] : run.bodies) n = 20;  // even
  auto policy = make_balance_policy(options);
  for (int s = 0; s < 8; ++s) {
    LoadView view = test::make_view(run.map, run.bodies, kTruth, 20 * s);
    if (s == 4) view.worlds[0].busy *= 5;  // one expensive period
    EXPECT_TRUE(policy->decide(view).empty()) << "period " << s;
  }
}

TEST(Diffusive, SameViewsSameDecisions) {
  BalanceOptions options;
  options.policy = "diffusive";
  options.seed = 7;
  CessionRun a = two_slabs(options), b = two_slabs(options);
  for (int s = 0; s < 6; ++s) {
    a.step(20 * s, options);
    b.step(20 * s, options);
  }
  EXPECT_EQ(a.history, b.history);
  EXPECT_EQ(a.map, b.map);
}

TEST(Diffusive, NeverGivesAWorldsLastCell) {
  BalanceOptions options;
  options.policy = "diffusive";
  const CellBox box{{0, 0, 0}, {4, 0, 0}};
  CessionRun run{test::make_map(box, 2, [](const CellCoord& c) { return c.x == 0 ? 0 : 1; }), {{{0, 0, 0}, 500}},
          make_balance_policy(options), {}};
  for (int s = 0; s < 5; ++s) run.step(20 * s, options);
  EXPECT_EQ(run.map.cell_count(0), 1);
}

// Three slabs in a row, all the load at the far end of the last, 13
// columns of empty cells away from world 1: world 0 (2 columns of cells,
// less than its share of 35) has only world 1 next to it, which holds no
// load (nothing to ask for, a desert) — famine. After kDesertFaminePeriods
// balance steps it gives its cells to world 1 and takes over part of world
// 2's territory; in the end every world has load.
TEST(Diffusive, AStarvingWorldRelocates) {
  BalanceOptions options;
  options.policy = "diffusive";
  // One cell per move: at more the load reaches world 1 (empty cells follow
  // the loaded ones for free) before world 0 starves.
  options.max_cells_per_move = 1;
  const CellBox box{{0, 0, 0}, {25, 0, 3}};
  CessionRun run{test::make_map(box, 3, [](const CellCoord& c) { return c.x < 2 ? 0 : (c.x < 10 ? 1 : 2); }), {},
                 make_balance_policy(options), {}};
  for (int x = 23; x < 26; ++x)
    for (int z = 0; z < 4; ++z) run.bodies[{x, 0, z}] = 40;
  EXPECT_GT(test::busy_imbalance(test::make_view(run.map, run.bodies, kTruth)), 2.5);
  double imbalance = 0;
  for (int s = 0; s < 60; ++s) imbalance = run.step(20 * s, options);
  EXPECT_GE(run.bestowals, 1);
  const LoadView end = test::make_view(run.map, run.bodies, kTruth);
  for (const WorldLoad& w : end.worlds) EXPECT_GT(w.bodies, 0) << "world " << w.world;
  EXPECT_LT(imbalance, 1.5);  // 12 loaded cells for 3 worlds: a cell is 25 % of a world's share
}

TEST(Diffusive, UnknownNamesAndBadOptionsAreRefused) {
  BalanceOptions options;
  options.policy = "diffusive";
  options.max_cells_per_move = 0;
  EXPECT_THROW(make_balance_policy(options), BalanceError);
  options.max_cells_per_move = 4;
  options.policy = "difusive";
  EXPECT_THROW(make_balance_policy(options), BalanceError);
}

}  // namespace
}  // namespace soda
