// Per-stage costs (WorldMetrics::stages, soda/runtime/stage.h): what the
// stages count adds up to the world's own counters, and their CPU times sum
// to the world's CPU time by construction. No timing is asserted: only sums
// of one clock's readings and counts. Label "concurrency" (a thread per world).
#include "runtime/partitioned_test_util.h"

#include <cmath>

namespace soda {
namespace {

std::size_t at(Stage s) { return static_cast<std::size_t>(s); }

void expect_consistent(const WorldMetrics& m) {
  double cpu = 0, waits = 0;
  std::uint64_t messages = 0;
  for (const StageCost& c : m.stages) {
    EXPECT_GE(c.cpu_seconds, 0.0);
    cpu += c.cpu_seconds;
    waits += c.wait_seconds;
    messages += c.messages;
  }
  // Integer nanoseconds summed, then each turned into seconds: equal up to
  // the rounding of those conversions.
  EXPECT_NEAR(cpu, m.cpu_seconds, 1e-9 * kStageCount + 1e-12 * m.cpu_seconds) << "world " << m.world;
  EXPECT_NEAR(waits, m.blocked_seconds + m.buffer_blocked_seconds, 1e-9 * kStageCount) << "world " << m.world;
  EXPECT_EQ(messages, m.messages_sent) << "world " << m.world;
  EXPECT_EQ(m.stages[at(Stage::ExchangeGhosts)].items, m.ghosts_received);
  EXPECT_EQ(m.stages[at(Stage::BuildIslands)].items, m.local_islands);
  EXPECT_EQ(m.stages[at(Stage::Glue)].items, m.border_fragments);
  EXPECT_EQ(m.stages[at(Stage::Merge)].items, m.merged_islands);
  EXPECT_EQ(m.stages[at(Stage::Solve)].items, m.islands_solved);
  EXPECT_EQ(m.stages[at(Stage::Migrate)].items, m.migrations_in + m.migrations_out);
  EXPECT_EQ(m.stages[at(Stage::Rollback)].items, m.rollbacks);
  EXPECT_GT(m.stages[at(Stage::Predict)].items, 0u);
  EXPECT_GT(m.stages[at(Stage::Collide)].cpu_seconds, 0.0);
}

TEST(StageCosts, AddUpPerWorld) {
  const Scene s = test::scene("falling-cubes", 200);
  const TerritoryMap map = make_partition("kmeans", s, 3, GridOptions{});
  for (Schedule schedule : {Schedule::Sequential, Schedule::ThreadPerWorld}) {
    PartitionedWorld world(s, map, PartitionedOptions{.schedule = schedule});
    world.step(120);
    std::uint64_t bytes = 0;
    for (const WorldMetrics& m : world.metrics()) {
      expect_consistent(m);
      for (const StageCost& c : m.stages) bytes += c.bytes;
      // Every stage interval lies within the thread's own clock's span.
      if (schedule == Schedule::ThreadPerWorld) {
        EXPECT_GT(m.thread_cpu_seconds, 0.0);
        EXPECT_GE(m.thread_cpu_seconds + 1e-9 * kStageCount, m.cpu_seconds);
      } else {
        EXPECT_EQ(m.thread_cpu_seconds, 0.0);  // one thread for every world: no world's own
      }
    }
    EXPECT_EQ(bytes, world.bytes_sent());
    EXPECT_GT(test::total(world.metrics()).stages[at(Stage::Merge)].items, 0u);
  }
}

TEST(StageCosts, CountRollbacks) {
  const Scene s = test::scene("falling-cubes", 200);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  PartitionedWorld world(
      s, map, PartitionedOptions{.schedule = Schedule::ThreadPerWorld, .runtime = {.anticipation = 8, .eager_bets = true}});
  world.step(60);
  for (const WorldMetrics& m : world.metrics()) expect_consistent(m);
  EXPECT_GT(test::total(world.metrics()).stages[at(Stage::Checkpoint)].items, 0u);
}

}  // namespace
}  // namespace soda
