// Reach beyond adjacent cells (docs/partitioned-step.md, "Reach beyond
// adjacent cells"): a ball thrown at 100 m/s (4.2 cells of 0.4 m per step)
// through a row of bricks across territories one cell thick, and at 40 m/s
// in its walled box cut grid:4x1x4 into one-cell columns. The worlds' neighbourhoods are widened to
// the scene's reach, so ghosts, migrants and merged islands go straight to
// every world a body can reach; every run must end on the one-territory
// hash — sequential and a thread per world, lockstep and speculating — and
// a run whose reach is too small must stop with an error naming the body,
// its speed and the remedy. Label "concurrency" (ThreadSanitizer in CI).
#include "runtime/partitioned_test_util.h"

#include <algorithm>

namespace soda {
namespace {

struct ReachCase {
  int speed;              // m/s, the scene's n
  const char* partition;
  int territories;
  CellBox box;            // the map's box of 0.4 m cells: territories one cell thick
  int steps;
};

GridOptions grid_of(const ReachCase& c) {
  GridOptions g;
  g.origin = Vec3::Zero();
  g.box = c.box;
  return g;
}

const std::vector<ReachCase> kCases = {
    // x in [-1.6, 1.6): one cell per world along the ball's line.
    {100, "grid:8x1x1", 8, CellBox{{-4, 0, -1}, {3, 0, 0}}, 120},
    // 1.6 m x 1.6 m around the origin: 16 one-cell columns (slabs beyond).
    {40, "grid:4x1x4", 16, CellBox{{-2, 0, -2}, {1, 0, 1}}, 150},
};

#if defined(__SANITIZE_THREAD__)
const std::vector<Schedule> kSchedules = {Schedule::ThreadPerWorld};
#else
const std::vector<Schedule> kSchedules = {Schedule::Sequential, Schedule::ThreadPerWorld};
#endif

TEST(Reach, FastBallAcrossThinTerritoriesMatchesOneTerritory) {
  for (const ReachCase& c : kCases) {
    const Scene s = test::scene("thrown-ball", c.speed);
    const TerritoryMap map = make_partition(c.partition, s, c.territories, grid_of(c));
    const std::uint64_t reference = test::reference_hash(s, c.steps);
    for (int anticipation : {0, 8})
      for (Schedule schedule : kSchedules) {
        PartitionedOptions o;
        o.schedule = schedule;
        o.runtime.anticipation = anticipation;
        o.runtime.validate = true;
        PartitionedWorld world(s, map, o);
        world.step(c.steps);
        const WorldMetrics t = test::total(world.metrics());
        std::size_t most_neighbours = 0;
        for (const WorldMetrics& m : world.metrics()) most_neighbours = std::max(most_neighbours, m.neighbours);
        const int reach = world.world(0).map().reach();
        std::printf("[ thrown-ball %d m/s %s %s K=%d anticipation %d %s ] reach %d cells, up to %zu neighbours; "
                    "one world %s, partitioned %s; %s; %llu messages, %llu bets\n",
                    c.speed, kPrecisionName, c.partition, c.territories, anticipation, schedule_name(schedule), reach,
                    most_neighbours, hash_hex(reference).c_str(), hash_hex(world.state_hash()).c_str(),
                    test::summary(t).c_str(), (unsigned long long)world.messages_sent(), (unsigned long long)t.bets);
        EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(reference))
            << c.speed << " m/s " << c.partition << " anticipation " << anticipation << " " << schedule_name(schedule);
        EXPECT_GT(reach, 1) << "the scene needs more than adjacent cells";
        EXPECT_GT(t.ghosts_sent, 0u);
        EXPECT_GT(t.migrations_out, 0u);
        EXPECT_GT(t.manifolds_seeded, 0u) << "contact state must cross worlds";
        if (c.territories == 16) {
          EXPECT_GT(t.merged_islands, 0u) << "the ball must hit bricks across a border";
        }
        if (anticipation == 0) {  // speculating, re-run steps count twice
          EXPECT_EQ(t.bets, 0u);
          EXPECT_EQ(t.ghosts_sent, t.ghosts_received);
          EXPECT_EQ(t.migrations_out, t.migrations_in);
        }
      }
  }
}

// The ball hits the bricks: one of them at least ends far from where it stood.
TEST(Reach, TheBallHitsTheBricks) {
  const Scene s = test::scene("thrown-ball", 100);
  PartitionedWorld world(s, make_partition("grid:8x1x1", s, 8, grid_of(kCases[0])), {});
  world.step(30);
  int moved = 0;
  for (const BodyState& b : world.body_states())
    for (const Body& d : s.bodies)
      if (d.id == b.id && d.id >= 6 && (Vec3(b.origin[0], b.origin[1], b.origin[2]) - d.position).norm() > 1.0)
        ++moved;
  EXPECT_GE(moved, 1);
}

// Neighbourhoods sized for a slow scene (reach 1: adjacent worlds only): the
// fast ball's halo reaches a world beyond them, and the run stops naming the
// body, its speed and the remedy.
TEST(Reach, TooSmallAReachIsRefusedNamingTheBodyAndTheRemedy) {
  for (const ReachCase& c : kCases) {
    const Scene s = test::scene("thrown-ball", c.speed);
    PartitionedOptions o;
    o.runtime.reach_speed = 1.0;  // covers 1 m/s: one cell
    PartitionedWorld world(s, make_partition(c.partition, s, c.territories, grid_of(c)), o);
    EXPECT_EQ(world.world(0).map().reach(), 1);
    try {
      world.step(c.steps);
      ADD_FAILURE() << c.partition << ": no error";
    } catch (const PartitionError& e) {
      const std::string what = e.what();
      std::printf("[ %s, reach 1 ] %s\n", c.partition, what.c_str());
      EXPECT_NE(what.find("body 5 moves at"), std::string::npos) << what;
      EXPECT_NE(what.find("--reach-speed"), std::string::npos) << what;
      EXPECT_NE(what.find("not a neighbour"), std::string::npos) << what;
    }
  }
}

// Slow scenes pay nothing: their reach is one cell, as before.
TEST(Reach, SlowScenesKeepAdjacentNeighbours) {
  for (const char* name : {"falling-cubes", "cube-pile", "projectile", "chain"}) {
    const Scene s = test::scene(name, 200);
    PartitionedWorld world(s, make_partition("kmeans", s, 4, GridOptions{}), {});
    EXPECT_EQ(world.world(0).map().reach(), 1) << name;
  }
}

TEST(Reach, ANegativeReachSpeedIsRefused) {
  const Scene s = test::scene("thrown-ball", 40);
  PartitionedOptions o;
  o.runtime.reach_speed = -1;
  EXPECT_THROW(PartitionedWorld(s, make_partition("grid:2x1x1", s, 2, GridOptions{}), o), std::invalid_argument);
}

}  // namespace
}  // namespace soda
