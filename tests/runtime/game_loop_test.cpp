// The game loop (docs/embedding.md, "The game loop"): a render thread reads
// every frame while the worlds run ahead of it, and gives inputs at the
// frame on screen (steps the worlds have already passed: each one a
// rollback) and at steps ahead of every world; bodies come and go. Every
// frame the reader returns equals the one-territory run's at that step, bit
// for bit, with every body alive at that step exactly once, for K = 1, 4
// and 8, lockstep and speculating. Label "concurrency" (ThreadSanitizer in
// CI).
#include <gtest/gtest.h>

#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "driver/testing_hooks.h"
#include "runtime/simulation_test_util.h"

namespace soda {
namespace {

constexpr int kSteps = 120;

using test::new_cube;
using test::unused_id;

// The inputs of the run: `at_frame` ones are given by the render thread once
// it has read the frame of their step and some world has finished the step
// after it (so each is at a step a world has passed: a rollback); the others
// are given ahead of every world (before the run, or far ahead of the frame
// on screen).
std::vector<test::PlannedInput> make_plan(const Scene& s) {
  std::vector<BodyId> dynamic;
  for (const Body& b : s.bodies)
    if (!b.is_static) dynamic.push_back(b.id);
  const BodyId a = unused_id(s), b = a + 1, c = a + 2;
  auto add = [](std::int64_t step, const Body& body) {
    UserInput in;
    in.kind = UserInput::Kind::AddBody;
    in.step = step;
    in.body = body;
    return in;
  };
  auto on = [](UserInput::Kind kind, std::int64_t step, BodyId id, Vec3 v = Vec3::Zero()) {
    UserInput in;
    in.kind = kind;
    in.step = step;
    in.id = id;
    in.linear = v;
    return in;
  };
  using K = UserInput::Kind;
  return {
      {add(20, new_cube(a, Vec3(0.3, 9, 0.2))), true},
      {on(K::ApplyImpulse, 30, dynamic[3], Vec3(2, 3, 0)), true},
      {add(60, new_cube(b, Vec3(-0.4, 11, 0.1))), false, 35},  // ahead of the worlds, during the run
      {on(K::RemoveBody, 45, dynamic[7]), true},
      {on(K::SetVelocity, 55, a, Vec3(1, 4, -1)), true},
      {on(K::RemoveBody, 75, a), true},
      {add(90, new_cube(c, Vec3(0.1, 8, -0.3))), false},  // before the run
      {on(K::RemoveBody, 100, dynamic[11]), false},
      {on(K::ApplyImpulse, 105, b, Vec3(0, 5, 0)), true},
  };
}

// The render thread's run for K territories, anticipation, threads (0: one
// per world, 1: one for all, else a pool) and the fuzzer's seed (0: off).
void expect_game_loop_equals_one_territory(int territories, int anticipation, int threads, std::uint64_t fuzz_seed) {
  const Scene s = test::scene("falling-cubes", 100);
  const std::vector<test::PlannedInput> plan = make_plan(s);
  static const test::QueuedRun ref = test::queued_run(s, plan, kSteps);

  test::Progress progress;
  SimulationConfig config{.territories = territories, .threads = threads, .buffer_capacity = 16, .past_inputs = true};
  config.runtime.anticipation = anticipation;
  config.after_step = progress.hook();
  if (fuzz_seed != 0) detail::edit_testing_hooks(config).fuzz_seed = fuzz_seed;
  Simulation sim(s, config);
  SceneReader reader = sim.add_reader();
  const test::RenderedRun run = test::run_game_loop(sim, reader, progress, plan, ref.frames, kSteps);
  const std::vector<std::size_t>& bodies = run.bodies;
  const std::uint64_t hash = sim.state_hash();
  sim.stop();
  std::printf("[ falling-cubes 100, K %d, anticipation %d, threads %d, fuzz %llu ] %zu rollbacks for %zu inputs at the "
              "frame on screen; bodies at frames 0/21/46/76/101: %zu/%zu/%zu/%zu/%zu; hash %s\n",
              territories, anticipation, threads, static_cast<unsigned long long>(fuzz_seed),
              static_cast<std::size_t>(sim.rollbacks()), run.at_frame, bodies.at(0),
              bodies.at(21), bodies.at(46), bodies.at(76), bodies.at(101), hash_hex(hash).c_str());
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_EQ(sim.rollbacks(), run.at_frame);  // every input at the frame on screen was at a past step
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.hash));
  EXPECT_EQ(bodies.at(0), 100u);
  EXPECT_EQ(bodies.at(21), 101u);  // a added at 20
  EXPECT_EQ(bodies.at(101), 100u);  // +a +b +c -7 -a -11
}

// territories, anticipation, threads
class GameLoop : public ::testing::TestWithParam<std::tuple<int, int, int>> {};

TEST_P(GameLoop, EveryFrameWhileBodiesComeAndGoEqualsOneTerritory) {
  const auto [territories, anticipation, threads] = GetParam();
  expect_game_loop_equals_one_territory(territories, anticipation, threads, 0);
}

// The fuzzer pauses every world at random, also between taking a pending
// rewind and reading its mailbox: a rollback for an input at the frame on
// screen then lands while a world is inside its advance, and its
// neighbours' first messages after it reach that world before it has taken
// it (messages.h, "rewinds"). Lockstep, where every past input is such a
// rewind; seeds, threads.
class GameLoopFuzzed : public ::testing::TestWithParam<std::tuple<std::uint64_t, int>> {};

TEST_P(GameLoopFuzzed, EveryFrameWhileWorldsPauseAtRandomEqualsOneTerritory) {
  const auto [seed, threads] = GetParam();
  expect_game_loop_equals_one_territory(4, 0, threads, seed);
}

INSTANTIATE_TEST_SUITE_P(Simulation, GameLoopFuzzed,
                         ::testing::Combine(::testing::Values<std::uint64_t>(3, 11), ::testing::Values(0, 1, 2)),
                         [](const auto& info) {
                           return "seed" + std::to_string(std::get<0>(info.param)) + "_threads" +
                                  std::to_string(std::get<1>(info.param));
                         });

INSTANTIATE_TEST_SUITE_P(Simulation, GameLoop,
                         ::testing::Values(std::tuple{1, 0, 0}, std::tuple{1, 8, 0}, std::tuple{4, 0, 0},
                                           std::tuple{4, 8, 0}, std::tuple{4, 0, 1}, std::tuple{4, 8, 1},
                                           std::tuple{4, 0, 2}, std::tuple{4, 8, 2}, std::tuple{8, 0, 0},
                                           std::tuple{8, 8, 0}, std::tuple{8, 8, 3}),
                         [](const auto& info) {
                           return "K" + std::to_string(std::get<0>(info.param)) + "_anticipation" +
                                  std::to_string(std::get<1>(info.param)) + "_threads" +
                                  std::to_string(std::get<2>(info.param));
                         });

// Without past_inputs an input at the frame on screen is refused, and the
// message says what to set.
TEST(GameLoopInput, AtAPassedStepWithoutPastInputsSaysWhatToSet) {
  const Scene s = test::scene("falling-cubes", 60);
  test::Progress progress;
  SimulationConfig config{.territories = 2, .buffer_capacity = 8};
  config.after_step = progress.hook();
  Simulation sim(s, config);
  SceneReader reader = sim.add_reader();
  sim.start(sim.time_of(40));
  std::optional<SceneFrame> f = reader.read_at(sim.time_of(10));
  ASSERT_TRUE(f.has_value());
  progress.wait_past(11);
  try {
    sim.apply_impulse(f->time, test::first_dynamic(s), Vec3(0, 1, 0));
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("past_inputs"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(reader.read_at(sim.time_of(40)).has_value());  // the reader moves on: the worlds may finish
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
}

}  // namespace
}  // namespace soda
