// User input through the Simulation: bodies added, removed, pushed and given
// velocities at scene step boundaries. The result depends only on the steps
// the inputs name — not on when the calls are made, nor on the territories:
// inputs queued before the run, and an input at a step a world ahead has
// already passed (applied by rolling every world back), end on the hash of
// the one-territory run. Label "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <cstdio>

#include "runtime/simulation_test_util.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

constexpr int kSteps = 160;

using test::first_dynamic;
using test::new_cube;
using test::unused_id;

// The same inputs, given before the run starts: 1 territory on one thread
// and 4 territories on threads (the inputs are in every world's future).
TEST(SimulationInput, QueuedInputsGiveTheOneTerritoryResult) {
  const Scene s = test::scene("cube-pile", 120);
  const BodyId pushed = first_dynamic(s), added = unused_id(s);
  auto run = [&](int territories, int threads, bool inputs) {
    Simulation sim(s, SimulationConfig{.territories = territories, .threads = threads});
    if (inputs) {
      EXPECT_EQ(sim.add_body(sim.time_of(40), new_cube(added, Vec3(0, 12, 0))), added);
      sim.set_velocity(sim.time_of(60), pushed, Vec3(3, 4, 0), Vec3(0, 1, 0));
      sim.apply_impulse(sim.time_of(70), added, Vec3(-2, 0, 1));
      sim.remove_body(sim.time_of(120), pushed);
    }
    EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
    return std::make_pair(sim.state_hash(), sim.body_count());
  };
  const auto one = run(1, 1, true);
  const auto four = run(4, 0, true);
  const auto none = run(1, 1, false);
  std::printf("inputs queued: 1 territory %s (%zu bodies), 4 territories %s; no input %s\n",
              hash_hex(one.first).c_str(), one.second, hash_hex(four.first).c_str(), hash_hex(none.first).c_str());
  EXPECT_EQ(hash_hex(four.first), hash_hex(one.first));
  EXPECT_EQ(four.second, one.second);
  EXPECT_EQ(one.second, none.second);  // one added, one removed
  EXPECT_NE(one.first, none.first);    // the inputs did something
}

// Thesis §3.2.3, late spawn: a 1x8 strip whose world 0 is held back
// (test::SpawnGate: after its step 20 it waits for the test; on one thread
// the round-robin order does it), so that the far end runs ahead; a body is
// added at a step the world that owns its position has already passed (but
// not older than the commit horizon). Every world rolls back to that step;
// the result equals the one-territory run with the body added at that step
// from the start.
class LateSpawn : public ::testing::TestWithParam<int> {};  // threads: 0 per world, 3 pool, 1 one

TEST_P(LateSpawn, InATerritoryThatIsAheadMatchesOneTerritory) {
  const Scene s = test::scene("falling-cubes", 200);
  const TerritoryMap map = make_partition("grid:8x1x1", s, 8, GridOptions{});
  // A position in the last territory, above everything.
  const std::optional<Vec3> spawn = test::far_spawn_point(s);
  ASSERT_TRUE(spawn.has_value());
  const Vec3 at = *spawn;
  ASSERT_EQ(map.owner_of(at), 7);
  const BodyId added = unused_id(s);

  test::SpawnGate gate(8, /*hold=*/GetParam() != 1);
  SimulationConfig config{.threads = GetParam(), .buffer_capacity = 64, .past_inputs = true};
  config.after_step = gate.hook();
  Simulation sim(s, map, config);
  sim.start(sim.time_of(kSteps));
  const Body cube = new_cube(added, at);
  // World 7 past the commit horizon. (Without speculation a world finishes
  // step t only with every neighbour's messages of t, so the lead along the
  // strip stays about a step.) The lockstep input holds every world, world
  // 0 too: the gate lets it go first.
  const test::Spawned spawned = gate.add_when_ahead(sim, cube, 7, 1, /*add_while_held=*/false);
  const std::int64_t step = spawned.step;
  ASSERT_GE(step, 0) << "world 7 never got ahead of the horizon";
  EXPECT_EQ(sim.rollbacks(), 1u);
  // Too old now: a clear error.
  try {
    sim.set_velocity(sim.time_of(0), added, Vec3(1, 0, 0));
    ADD_FAILURE() << "an input at step 0 was accepted";
  } catch (const std::invalid_argument& e) {
    std::printf("refused: %s\n", e.what());
  }
  test::expect_late_spawn_exact(sim, s, cube, step, kSteps,
                                "late spawn at step " + std::to_string(step) + " (threads " +
                                    std::to_string(GetParam()) + "; world 7 ahead of the horizon by " +
                                    std::to_string(spawned.lead) + ")");
}

INSTANTIATE_TEST_SUITE_P(SimulationInput, LateSpawn, ::testing::Values(0, 3, 1));

TEST(SimulationInput, BadInputIsRefusedWithAClearError) {
  const Scene s = test::scene("cube-pile", 60);
  Simulation sim(s, SimulationConfig{.territories = 2});
  const BodyId body = first_dynamic(s);
  auto refused = [&](const std::function<void()>& call, const std::string& needle) {
    try {
      call();
      ADD_FAILURE() << "accepted; expected: " << needle;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  refused([&] { sim.set_velocity(sim.time_of(5), unused_id(s), Vec3(1, 0, 0)); }, "no body has that id");
  refused([&] { sim.add_body(sim.time_of(5), new_cube(body, Vec3(0, 9, 0))); }, "is in use");
  refused([&] { sim.set_velocity(sim.time_of(5), body, Vec3(std::nan(""), 0, 0)); }, "finite");
  Body bad = new_cube(unused_id(s), Vec3(0, 9, 0));
  bad.mass = -1;
  refused([&] { sim.add_body(sim.time_of(5), bad); }, "mass");
  sim.remove_body(sim.time_of(10), body);
  refused([&] { sim.apply_impulse(sim.time_of(12), body, Vec3(1, 0, 0)); }, "not in the scene then");
  EXPECT_TRUE(sim.advance_to(sim.time_of(30)));
  refused([&] { sim.add_body(sim.time_of(20), new_cube(unused_id(s), Vec3(0, 9, 0))); }, "past_inputs");
  EXPECT_EQ(sim.body_count(), s.bodies.size() - 1);
}

}  // namespace
}  // namespace soda
