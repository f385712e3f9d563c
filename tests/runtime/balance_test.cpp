// Load balancing by cell cession (docs/loadbalance.md): at every balance step
// the worlds stop, cells change owner as the policy says and the worlds are
// rebuilt for the new map. Results never change: under `churn` (random cells
// every period) the state hash equals the one-territory run's for every K,
// with and without speculation, under SyncTest and with validation; cells
// and bodies really change hands; a world left with no cells (famine) keeps
// running, and comes back when given cells again.
#include <algorithm>
#include <cctype>
#include <map>
#include <mutex>
#include <vector>

#include "runtime/partitioned_test_util.h"
#include "soda/runtime/simulation.h"

namespace soda {
namespace {

struct Case {
  const char* scene;
  int n;
  int territories;
  int anticipation;
  int sync_test = 0;
  int steps = 100;
  int period = 5;
};

// border-shuttle crosses borders along x: strips grid:Kx1x1; the others kmeans.
std::string partition_of(const Case& c) {
  return std::string(c.scene) == "border-shuttle" ? "grid:" + std::to_string(c.territories) + "x1x1" : "kmeans";
}

// The one-territory hash of (scene, n, steps), computed once per test binary.
std::uint64_t one_territory_hash(const Scene& s, const std::string& key, int steps) {
  static std::mutex mutex;
  static std::map<std::string, std::uint64_t> cache;
  std::lock_guard lock(mutex);
  const std::string k = key + "/" + std::to_string(steps);
  auto it = cache.find(k);
  if (it == cache.end()) it = cache.emplace(k, test::reference_hash(s, steps)).first;
  return it->second;
}

PartitionedOptions churn_options(const Case& c, std::uint64_t seed = 7) {
  PartitionedOptions o;
  o.schedule = Schedule::ThreadPerWorld;
  o.runtime.validate = true;
  o.serialise = true;
  o.runtime.anticipation = c.anticipation;
  o.sync_test = c.sync_test;
  o.runtime.balance.policy = "churn";
  o.runtime.balance.period = c.period;
  o.runtime.balance.seed = seed;
  o.runtime.balance.max_cells_per_move = 3;
  return o;
}

class ChurnBalance : public ::testing::TestWithParam<Case> {};

TEST_P(ChurnBalance, CellsAndBodiesChangeHandsAndTheHashEqualsOneTerritory) {
  const Case c = GetParam();
  const Scene s = test::scene(c.scene, c.n);
  const TerritoryMap map = make_partition(partition_of(c), s, c.territories, GridOptions{});
  PartitionedWorld world(s, map, churn_options(c));
  world.step(c.steps);
  const BalanceTotals t = balance_totals(world.balance_log());
  EXPECT_EQ(t.balance_steps, (c.steps - 1) / c.period);  // none at step 0 nor at the last step
  EXPECT_GT(t.cells_moved, 0);
  EXPECT_GT(t.bodies_moved, 0);
  EXPECT_FALSE(world.map() == map_with_reach(s, map, 0)) << "the map must have changed";
  EXPECT_EQ(hash_hex(world.state_hash()),
            hash_hex(one_territory_hash(s, std::string(c.scene) + std::to_string(c.n), c.steps)));
  if (c.sync_test) {
    EXPECT_EQ(world.sync_rollbacks(), static_cast<std::uint64_t>(c.steps));
  }
  std::printf("[ churn %s %d K=%d anticipation %d sync-test %d ] %lld balance steps, %lld cells and %lld bodies "
              "moved, %.4f s CPU (apply %.4f s); %s\n",
              c.scene, c.n, c.territories, c.anticipation, c.sync_test, static_cast<long long>(t.balance_steps),
              static_cast<long long>(t.cells_moved), static_cast<long long>(t.bodies_moved), t.cpu_seconds(),
              t.apply_cpu_seconds, hash_hex(world.state_hash()).c_str());
}

INSTANTIATE_TEST_SUITE_P(Runtime, ChurnBalance,
                         ::testing::Values(Case{"falling-cubes", 200, 2, 0}, Case{"falling-cubes", 200, 4, 0},
                                           Case{"falling-cubes", 200, 8, 0}, Case{"falling-cubes", 200, 2, 8},
                                           Case{"falling-cubes", 200, 4, 8}, Case{"falling-cubes", 200, 8, 8},
                                           Case{"border-shuttle", 200, 2, 0, 0, 120, 10},
                                           Case{"border-shuttle", 200, 4, 0, 0, 120, 10},
                                           Case{"border-shuttle", 200, 8, 0, 0, 120, 10},
                                           Case{"border-shuttle", 200, 2, 8, 0, 120, 10},
                                           Case{"border-shuttle", 200, 4, 8, 0, 120, 10},
                                           Case{"border-shuttle", 200, 8, 8, 0, 120, 10},
                                           Case{"falling-cubes", 200, 4, 0, 3, 60, 5},
                                           Case{"border-shuttle", 200, 8, 0, 3, 60, 5}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           std::string n = std::string(info.param.scene) + "_K" +
                                           std::to_string(info.param.territories) + "_a" +
                                           std::to_string(info.param.anticipation) + "_sync" +
                                           std::to_string(info.param.sync_test);
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

// A cession rebuilds only the worlds it changes (a cell of theirs within the
// map's reach of a moved cell, or a recipient); the others keep their
// TerritoryWorld — Bullet world, pairs, contact state — and the hash still
// equals the one-territory run's. One cell per balance step on 8 strips
// leaves most worlds untouched. A new world is made before the old one is
// destroyed, so an unchanged address is a kept world.
TEST(BalanceCession, WorldsAwayFromTheMovedCellsKeepTheirBulletWorlds) {
#if defined(__SANITIZE_THREAD__)  // TSan looks for races, not hashes: the speculative run only
  const std::vector<int> anticipations = {8};
#else
  const std::vector<int> anticipations = {0, 8};
#endif
  for (const int anticipation : anticipations) {
    const Case c{"border-shuttle", 200, 8, anticipation, 0, 120, 10};
    const Scene s = test::scene(c.scene, c.n);
    const TerritoryMap map = make_partition(partition_of(c), s, c.territories, GridOptions{});
    PartitionedOptions o = churn_options(c);
    o.runtime.balance.max_cells_per_move = 1;
    PartitionedWorld world(s, map, o);
    int kept = 0, rebuilt = 0;
    for (int i = 0; i < c.steps; ++i) {
      std::vector<const TerritoryWorld*> before;
      for (WorldId w = 0; w < c.territories; ++w) before.push_back(&world.world(w));
      const std::size_t records = world.balance_log().size();
      world.step(1);
      if (world.balance_log().size() == records || world.balance_log().back().cells_moved == 0) continue;
      for (WorldId w = 0; w < c.territories; ++w) ++(&world.world(w) == before[static_cast<std::size_t>(w)] ? kept : rebuilt);
    }
    EXPECT_GT(kept, 0) << "anticipation " << anticipation;
    EXPECT_GT(rebuilt, 0) << "anticipation " << anticipation;
    EXPECT_EQ(hash_hex(world.state_hash()),
              hash_hex(one_territory_hash(s, std::string(c.scene) + std::to_string(c.n), c.steps)))
        << "anticipation " << anticipation;
    std::printf("[ cession, anticipation %d ] worlds kept %d, rebuilt %d over the balance steps with moves\n",
                anticipation, kept, rebuilt);
  }
}

// The per-step loads and the balance log add up: every scene step once, the
// cells of every step summing to the box, the bodies to the scene's dynamic
// bodies, the busy CPU to the worlds' metrics (carried across rebuilds).
TEST(BalanceLog, StepLoadsAddUpAcrossRebuilds) {
  const Case c{"falling-cubes", 200, 4, 0, 0, 40, 10};
  const Scene s = test::scene(c.scene, c.n);
  const TerritoryMap map = make_partition("kmeans", s, c.territories, GridOptions{});
  PartitionedOptions o = churn_options(c);
  o.runtime.validate = false;
  PartitionedWorld world(s, map, o);
  world.step(25);
  world.step(15);
  ASSERT_EQ(world.step_loads().size(), 40u);
  const std::int64_t box_cells = world.map().box().count();
  double busy = 0;
  for (std::size_t i = 0; i < world.step_loads().size(); ++i) {
    const StepLoads& sl = world.step_loads()[i];
    EXPECT_EQ(sl.step, static_cast<std::int64_t>(i) + 1);
    ASSERT_EQ(sl.worlds.size(), 4u);
    std::int64_t cells = 0, bodies = 0;
    for (const WorldStepLoad& w : sl.worlds) {
      cells += w.cells;
      bodies += w.bodies;
      busy += w.busy_seconds;
      EXPECT_EQ(w.lead, 0);
      EXPECT_GT(w.busy_seconds, 0.0);
    }
    EXPECT_EQ(cells, box_cells) << "step " << sl.step;
    EXPECT_EQ(bodies, static_cast<std::int64_t>(s.dynamic_count())) << "step " << sl.step;
  }
  double cpu = 0;
  for (const WorldMetrics& m : world.metrics()) cpu += m.cpu_seconds;
  EXPECT_NEAR(busy, cpu, 1e-6 * cpu + 1e-9);
  ASSERT_EQ(world.balance_log().size(), 3u);  // steps 10, 20, 30 (40 is the last: nothing after it)
  for (std::size_t i = 0; i < 3; ++i) {
    const BalanceRecord& r = world.balance_log()[i];
    EXPECT_EQ(r.step, 10 * static_cast<std::int64_t>(i + 1));
    EXPECT_EQ(r.cells_moved, static_cast<std::int64_t>(r.moves.size()));
    EXPECT_EQ(r.cells_owned.size(), 4u);
    // Per world: what it gave and took adds up to the totals, and matches the moves.
    ASSERT_EQ(r.cells_out.size(), 4u);
    ASSERT_EQ(r.bodies_in.size(), 4u);
    std::int64_t cells_out = 0, cells_in = 0, bodies_out = 0, bodies_in = 0;
    for (std::size_t w = 0; w < 4; ++w) {
      cells_out += r.cells_out[w], cells_in += r.cells_in[w];
      bodies_out += r.bodies_out[w], bodies_in += r.bodies_in[w];
      const auto gives = std::count_if(r.moves.begin(), r.moves.end(),
                                       [&](const CellMove& m) { return m.from == static_cast<WorldId>(w); });
      EXPECT_EQ(r.cells_out[w], gives);
    }
    EXPECT_EQ(cells_out, r.cells_moved);
    EXPECT_EQ(cells_in, r.cells_moved);
    EXPECT_EQ(bodies_out, r.bodies_moved);
    EXPECT_EQ(bodies_in, r.bodies_moved);
    // The cells owned during the step after a balance step are the record's.
    const StepLoads& after = world.step_loads()[static_cast<std::size_t>(r.step)];
    for (std::size_t w = 0; w < 4; ++w) EXPECT_EQ(after.worlds[w].cells, r.cells_owned[w]);
  }
  // The map now is the first one with every move applied in order.
  TerritoryMap replayed = map_with_reach(s, map, 0);
  for (const BalanceRecord& r : world.balance_log()) {
    std::vector<std::pair<CellCoord, WorldId>> changes;
    for (const CellMove& m : r.moves) changes.emplace_back(m.cell, m.to);
    replayed = replayed.reassigned(changes);
  }
  EXPECT_TRUE(replayed == world.map());
}

// Gives every cell of one world to another at the first balance step, and
// some cells back (those holding bodies first) at a later one.
class FamineThenFeast final : public BalancePolicy {
 public:
  FamineThenFeast(WorldId starved, std::int64_t feast_at) : starved_(starved), feast_at_(feast_at) {}
  const char* name() const override { return "famine-then-feast"; }
  std::vector<CellMove> decide(const LoadView& view) override {
    std::vector<CellMove> moves;
    const TerritoryMap& map = *view.map;
    if (!starved_once_) {
      starved_once_ = true;
      const WorldId to = starved_ == 0 ? 1 : 0;
      for (const CellCoord& c : map.cells_of(starved_)) moves.push_back({c, starved_, to});
    } else if (view.step == feast_at_) {
      for (const CellLoad& c : view.cells)
        if (c.owner != starved_ && moves.size() < 3) moves.push_back({c.cell, c.owner, starved_});
    }
    views_.push_back(view.worlds[static_cast<std::size_t>(starved_)]);
    return moves;
  }
  std::vector<WorldLoad> views_;  // the starved world's load at every balance step

 private:
  WorldId starved_;
  std::int64_t feast_at_;
  bool starved_once_ = false;
};

class Famine : public ::testing::TestWithParam<int> {};

TEST_P(Famine, AWorldWithoutCellsKeepsRunningAndComesBack) {
  const int anticipation = GetParam();
  const Scene s = test::scene("falling-cubes", 200);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  auto policy = std::make_shared<FamineThenFeast>(2, 40);
  PartitionedOptions o;
  o.schedule = Schedule::ThreadPerWorld;
  o.runtime.validate = true;
  o.runtime.anticipation = anticipation;
  o.runtime.balance.period = 10;
  o.balance_policy = policy;
  PartitionedWorld world(s, map, o);
  world.step(30);  // starved at step 10; steps 11..30 with no cells
  EXPECT_EQ(world.map().cell_count(2), 0);
  EXPECT_EQ(world.world(2).owned_count(), 0u);
  EXPECT_TRUE(world.world(2).neighbours().empty());
  for (std::size_t i = 10; i < 30; ++i) {
    EXPECT_EQ(world.step_loads()[i].worlds[2].bodies, 0);
    EXPECT_EQ(world.step_loads()[i].worlds[2].cells, 0);
  }
  world.step(30);  // fed 3 loaded cells at step 40
  ASSERT_EQ(policy->views_.size(), 5u);
  EXPECT_EQ(policy->views_[1].cells, 0);  // at step 20: starving
  EXPECT_EQ(policy->views_[1].bodies, 0);
  EXPECT_GT(world.map().cell_count(2), 0);
  EXPECT_GT(world.balance_log()[3].bodies_moved, 0);  // step 40
  EXPECT_GT(policy->views_[4].bodies, 0);           // at step 50 world 2 owns bodies again
  EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(one_territory_hash(s, "falling-cubes200", 60)));
}

INSTANTIATE_TEST_SUITE_P(Runtime, Famine, ::testing::Values(0, 8));

// A policy that breaks its contract stops the run naming it and the move.
class WrongOwner final : public BalancePolicy {
 public:
  const char* name() const override { return "wrong-owner"; }
  std::vector<CellMove> decide(const LoadView& view) override {
    const CellLoad& c = view.cells.front();
    return {CellMove{c.cell, c.owner == 0 ? 1 : 0, c.owner == 0 ? 2 : 2}};
  }
};

TEST(BalanceContract, AMoveFromAWorldThatDoesNotOwnTheCellIsRefused) {
  const Scene s = test::scene("falling-cubes", 100);
  PartitionedOptions o;
  o.runtime.balance.period = 5;
  o.balance_policy = std::make_shared<WrongOwner>();
  PartitionedWorld world(s, make_partition("kmeans", s, 3, GridOptions{}), o);
  try {
    world.step(10);
    FAIL() << "expected std::logic_error";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("wrong-owner"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("owns the cell"), std::string::npos) << e.what();
  }
}

TEST(BalanceOptions, BadValuesAreRefusedAtConstruction) {
  const Scene s = test::scene("falling-cubes", 50);
  const TerritoryMap map = make_partition("kmeans", s, 2, GridOptions{});
  PartitionedOptions o;
  o.runtime.balance.policy = "churn";
  o.runtime.balance.period = 0;
  EXPECT_THROW(PartitionedWorld(s, map, o), BalanceError);
  o.runtime.balance.period = 5;
  o.runtime.balance.policy = "no-such-policy";
  EXPECT_THROW(PartitionedWorld(s, map, o), BalanceError);
}

TEST(BalanceOptions, ASimulationRefusesAPolicyItCannotApply) {
  const Scene s = test::scene("falling-cubes", 50);
  SimulationConfig c;
  c.territories = 2;
  c.runtime.balance.policy = "churn";
  try {
    Simulation sim(s, c);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("load balancing"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace soda
