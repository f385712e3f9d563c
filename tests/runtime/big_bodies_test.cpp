// Bodies of any size (docs/determinism.md, "Bodies of any size"): boxes,
// capsules and hulls of 2 m, 5 m and 20 m across fall among unit cubes and
// span many cells and territories. Their manifolds break at the capped
// threshold (worlds/src/contact_threshold.h), their halos reach every cell
// they overlap and the neighbourhoods reach as far as they do, so K
// territories give the one-world hash — lockstep, speculating and under
// SyncTest. An input that adds a body larger than the run's reach is
// refused, naming its size and the largest the run takes.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "runtime/partitioned_test_util.h"
#include "runtime/simulation_test_util.h"

namespace soda {
namespace {

constexpr int kSteps = 150;

struct BigCase {
  int territories;
  int anticipation;
  int sync_test;
};

class BigBodies : public ::testing::TestWithParam<BigCase> {};

TEST_P(BigBodies, EqualTheOneWorldHash) {
  const BigCase c = GetParam();
  const Scene s = test::scene("big-bodies", 150);
  static const std::uint64_t reference = test::reference_hash(s, kSteps);
  const TerritoryMap map = make_partition("kmeans", s, c.territories, GridOptions{});
  PartitionedOptions o;
  o.runtime.anticipation = c.anticipation;
  o.sync_test = c.sync_test;
  if (c.territories > 1) {
    o.schedule = Schedule::Pool;
    o.threads = 2;
  }
  PartitionedWorld w(s, map, o);
  w.step(kSteps);
  const WorldMetrics t = test::total(w.metrics());
  std::printf("[ big-bodies 150, K %d, anticipation %d, sync-test %d, cells %.3f m, reach %d ] %s, %s one world %s\n",
              c.territories, c.anticipation, c.sync_test, w.map().grid().cell_size(), w.map().reach(),
              test::summary(t).c_str(), hash_hex(w.state_hash()).c_str(), hash_hex(reference).c_str());
  EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference));
  if (c.territories > 1) {
    EXPECT_GT(t.migrations_out, 0u);
    EXPECT_GT(t.ghosts_sent, 0u);
  }
  if (c.anticipation > 0 && c.territories > 1) EXPECT_GT(t.bets, 0u);
  if (c.sync_test > 0) EXPECT_GT(w.sync_rollbacks(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Partitioned, BigBodies,
                         ::testing::Values(BigCase{1, 0, 0}, BigCase{2, 0, 0}, BigCase{4, 0, 0}, BigCase{8, 0, 0},
                                           BigCase{4, 8, 0}, BigCase{8, 8, 0}, BigCase{4, 0, 2}),
                         [](const auto& info) {
                           return "K" + std::to_string(info.param.territories) + "_anticipation" +
                                  std::to_string(info.param.anticipation) + "_sync" +
                                  std::to_string(info.param.sync_test);
                         });

// The default cell is a unit cube's: the 20 m beam spans a dozen cells
// and the neighbourhoods reach across them.
TEST(BigBodiesGrid, CellsFitTheCubesAndTheReachTheBeam) {
  const Scene s = test::scene("big-bodies", 150);
  EXPECT_DOUBLE_EQ(default_cell_size(s), std::sqrt(3.0));
  EXPECT_GT(s.largest_dynamic_extent(), 20.0);
  const PartitionedWorld w(s, make_partition("kmeans", s, 4, GridOptions{}), PartitionedOptions{});
  EXPECT_GE(w.map().reach() * w.map().grid().cell_size(), 10.0);  // the beam's bounding radius
}

// A body larger than the run's reach is refused when it is added, with its
// size and the largest the run takes; with room given up front it is taken.
TEST(BigBodiesInput, TooLargeForTheReachIsRefusedUnlessGivenRoom) {
  const Scene s = test::scene("falling-cubes", 100);
  Body ship;
  ship.id = test::unused_id(s);
  ship.shape = Shape::box(Vec3(25.0, 2.0, 5.0));  // a 50 m ship
  ship.mass = 5000;
  ship.position = Vec3(0, 40, 0);
  std::vector<std::uint64_t> hashes;
  for (int k : {1, 4}) {
    Simulation sim(s, SimulationConfig{.territories = k});
    try {
      sim.add_body(sim.time_of(10), ship);
      ADD_FAILURE() << "a 50 m body was accepted by a run sized for unit cubes (K " << k << ")";
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      std::printf("K %d: %s\n", k, what.c_str());
      EXPECT_NE(what.find("m across"), std::string::npos) << what;
      EXPECT_NE(what.find("added_extent"), std::string::npos) << what;
    }
    SimulationConfig roomy{.territories = k};
    roomy.runtime.added_extent = 2.0 * ship.shape.bounding_radius();
    Simulation big(s, roomy);
    EXPECT_EQ(big.add_body(big.time_of(10), ship), ship.id);
    EXPECT_TRUE(big.advance_to(big.time_of(40)));
    EXPECT_EQ(big.body_count(), s.bodies.size() + 1);
    hashes.push_back(big.state_hash());
  }
  EXPECT_EQ(hash_hex(hashes[1]), hash_hex(hashes[0]));  // the ship on 4 territories as on one
}

}  // namespace
}  // namespace soda
