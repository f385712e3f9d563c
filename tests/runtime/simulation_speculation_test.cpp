// Speculation under a Simulation (RuntimeOptions::anticipation,
// docs/rollback.md): worlds run ahead of the commit horizon and publish
// speculative entries; rollbacks republish them with new revisions. Readers,
// advance_to and the readouts only ever see committed steps, so every frame
// read and every hash equals the one-territory run's; an input at a past
// step is a rollback of every world on the rollback board. Label
// "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <thread>
#include <vector>

#include "runtime/simulation_test_util.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

std::string name_of(int threads) {
  return threads == 0 ? "thread per world" : threads == 1 ? "one thread" : "pool of " + std::to_string(threads);
}

class SpeculativeSimulation : public ::testing::TestWithParam<int> {};  // threads: 0 per world, 3 pool, 1 one

// A 1x8 strip, eager bets (the most rollbacks), a reader reading every step
// while the worlds run: every frame is the one-territory frame bit for bit,
// and so is the final hash; re-runs rejoin their old runs and republish the
// entries of the steps they take back.
TEST_P(SpeculativeSimulation, FramesAndHashEqualOneTerritory) {
  constexpr int kSteps = 60;
  const Scene s = test::scene("falling-cubes", 100);
  const test::Reference ref = test::reference_run(s, kSteps);
  const TerritoryMap map = make_partition("grid:8x1x1", s, 8, GridOptions{});
  SimulationConfig config{.threads = GetParam(), .buffer_capacity = 16};
  config.runtime.anticipation = 8;
  config.runtime.checkpoint_every = 1;
  config.runtime.eager_bets = true;
  Simulation sim(s, map, config);
  std::atomic<int> bad_frames{0};
  std::thread reader([&, r = sim.add_reader()]() mutable {
    for (int k = 0; k <= kSteps; ++k) {
      std::optional<SceneFrame> f = r.read_at(sim.time_of(k));
      if (!f || f->step != k || !test::frame_difference(f->poses, ref.frames[static_cast<std::size_t>(k)]).empty())
        ++bad_frames;
    }
  });
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  EXPECT_GE(sim.commit_horizon_step(), kSteps);
  reader.join();
  const WorldMetrics t = test::total(sim.metrics());
  std::printf("[ falling-cubes 100 grid:8x1x1 %s anticipation 8, %s ] %llu bets, %llu lost, %llu rollbacks, %llu of "
              "%llu steps rolled back rejoined, %llu bodies re-solved, %llu replayed, lead max %lld\n",
              kPrecisionName, name_of(GetParam()).c_str(), (unsigned long long)t.bets,
              (unsigned long long)t.bets_lost, (unsigned long long)t.rollbacks,
              (unsigned long long)t.steps_rejoined, (unsigned long long)t.steps_rolled_back,
              (unsigned long long)t.bodies_resolved, (unsigned long long)t.bodies_replayed, (long long)t.lead_max);
  EXPECT_GT(t.bets, 0u);
  // On one thread the worlds run round-robin and the far end runs ahead,
  // loses bets and rolls back in every run; a thread per world or a pool
  // may as well keep in step (the counts follow their timing).
  if (GetParam() == 1) {
    EXPECT_GT(t.rollbacks, 0u);
    EXPECT_GT(t.steps_rejoined, 0u);  // re-runs rejoined, their steps' entries republished
  }
  EXPECT_EQ(bad_frames.load(), 0);
  EXPECT_EQ(sim.steps_done(), kSteps);
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[kSteps]));
}

// Thesis §3.2.3, late spawn under speculation: a 1x8 strip, anticipation
// 16, on one thread: the round-robin order runs the far end ahead
// (deterministic, no timing; a world held back on a thread of its own
// could not repair its lost bets, and every world would wait for it). A
// body is added at a step the world at the far end (which owns its
// position) has passed, 2 or more steps ahead of the horizon (its borders
// are busy: few bets, so little more). Every world rolls back to that step
// on the rollback board, without being held; the result equals the
// one-territory run with the body added at that step from the start.
TEST(SimulationSpeculation, LateSpawnInATerritoryThatIsAheadMatchesOneTerritory) {
  constexpr int kSteps = 120;
  const Scene s = test::scene("falling-cubes", 200);
  const TerritoryMap map = make_partition("grid:8x1x1", s, 8, GridOptions{});
  const std::optional<Vec3> spawn = test::far_spawn_point(s);
  ASSERT_TRUE(spawn.has_value());
  const WorldId target = map.owner_of(*spawn);  // the far end of the strip
  ASSERT_GE(target, 5);
  const BodyId added = test::unused_id(s);
  const Body cube = test::new_cube(added, *spawn);

  test::SpawnGate gate(8, /*hold=*/false);
  SimulationConfig config{.threads = 1, .buffer_capacity = 64, .past_inputs = true};
  config.runtime.anticipation = 16;
  config.runtime.eager_bets = true;
  config.after_step = gate.hook();
  Simulation sim(s, map, config);
  sim.start(sim.time_of(kSteps));
  const test::Spawned spawned = gate.add_when_ahead(sim, cube, target, 2, /*add_while_held=*/true);
  const std::int64_t step = spawned.step;
  ASSERT_GE(step, 0) << "world " << target << " never got 2 steps ahead of the horizon";
  EXPECT_EQ(sim.rollbacks(), 1u);
  test::expect_late_spawn_exact(sim, s, cube, step, kSteps,
                                "speculative late spawn at step " + std::to_string(step) + " (" +
                                    name_of(1) + "; world " + std::to_string(target) + " " +
                                    std::to_string(spawned.lead) + " steps ahead of the horizon)");
}

INSTANTIATE_TEST_SUITE_P(SimulationSpeculation, SpeculativeSimulation, ::testing::Values(0, 3, 1));

TEST(SimulationSpeculation, BufferTooSmallForTheAnticipationIsRefused) {
  const Scene s = test::scene("falling-cubes", 40);
  SimulationConfig config{.territories = 2, .buffer_capacity = 8};
  config.runtime.anticipation = 6;
  try {
    Simulation sim(s, config);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("anticipation + 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace soda
