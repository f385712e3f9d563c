// Simulation (the embedding API): whole-scene frames equal the one-world
// run bit for bit at every step, for every schedule, read from another
// thread while the worlds run; advance_to / run_for / start semantics;
// interpolated and non-blocking reads. Label "concurrency" (ThreadSanitizer
// in CI): small scenes, few steps.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <thread>

#include "runtime/simulation_test_util.h"
#include "soda/grid/partition.h"
#include "soda/scene/registry.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr int kSteps = 100;

std::string name_of(int threads) {
  return threads == 0 ? "thread per world" : threads == 1 ? "one thread" : "pool of " + std::to_string(threads);
}

// A render thread reads every step while the worlds run freely; every frame
// is the reference's, bit for bit; cube-pile migrates bodies between worlds
// (each counted once: the reader checks it on every read).
TEST(Simulation, FramesMatchOneWorldBitForBit) {
  const Scene s = test::scene("cube-pile", 120);
  const test::Reference ref = test::reference_run(s, kSteps);
  for (int threads : {0, 2, 1}) {
    Simulation sim(s, SimulationConfig{.territories = 4, .threads = threads, .buffer_capacity = 8});
    SceneReader reader = sim.add_reader();
    std::vector<SceneFrame> frames;
    std::thread render([&] {
      for (int k = 0; k <= kSteps; ++k)
        if (std::optional<SceneFrame> f = reader.read_at(sim.time_of(k))) frames.push_back(std::move(*f));
    });
    sim.start(sim.time_of(kSteps));
    EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
    render.join();
    ASSERT_EQ(frames.size(), static_cast<std::size_t>(kSteps + 1)) << name_of(threads);
    for (int k = 0; k <= kSteps; ++k) {
      EXPECT_EQ(frames[k].step, k);
      EXPECT_EQ(frames[k].time, k * s.settings.dt);
      const std::string diff = test::frame_difference(frames[k].poses, ref.frames[k]);
      EXPECT_EQ(diff, "") << name_of(threads) << ", step " << k;
      if (!diff.empty()) break;
    }
    EXPECT_EQ(sim.steps_done(), kSteps);
    const WorldMetrics total = test::total(sim.metrics());
    std::printf("[ cube-pile 120 %s K=4 %s ] one world %s, simulation %s, %llu migrations, %llu border islands\n",
                kPrecisionName, name_of(threads).c_str(), hash_hex(ref.hashes[kSteps]).c_str(),
                hash_hex(sim.state_hash()).c_str(), static_cast<unsigned long long>(total.migrations_out),
                static_cast<unsigned long long>(total.islands_solved));
    EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[kSteps]));
    EXPECT_GT(total.migrations_out, 0u);
    sim.stop();
  }
}

// Without start(), advance_to runs the worlds exactly to the time and parks
// them there; run_for adds simulated seconds; start(end) runs up to end.
TEST(Simulation, AdvanceToAndRunFor) {
  const Scene s = test::scene("falling-cubes", 150);
  const test::Reference ref = test::reference_run(s, 60);
  Simulation sim(s, SimulationConfig{.territories = 4, .partition = "rcb"});
  EXPECT_EQ(sim.published_step(), 0);
  EXPECT_EQ(sim.steps_done(), 0);
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[0]));

  EXPECT_TRUE(sim.advance_to(0.5));
  EXPECT_EQ(sim.steps_done(), 30);
  EXPECT_EQ(sim.published_step(), 30);
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[30]));

  EXPECT_TRUE(sim.run_for(0.25));
  EXPECT_EQ(sim.steps_done(), 45);
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[45]));

  EXPECT_TRUE(sim.advance_to(0.1));  // already published: returns at once, the limit stays
  EXPECT_EQ(sim.steps_done(), 45);

  sim.start(1.0);  // free run up to 1 s
  EXPECT_TRUE(sim.advance_to(1.0));
  EXPECT_EQ(sim.steps_done(), 60);
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[60]));
  EXPECT_THROW(sim.advance_to(-1.0), std::invalid_argument);
  EXPECT_THROW(sim.run_for(-1.0), std::invalid_argument);

  sim.stop();
  EXPECT_TRUE(sim.stopped());
  EXPECT_EQ(sim.steps_done(), 60);
  EXPECT_TRUE(sim.advance_to(0.5));   // published before the stop
  EXPECT_FALSE(sim.advance_to(2.0));  // never will be
  EXPECT_THROW(sim.start(), std::logic_error);
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[60]));
}

TEST(Simulation, TimesToStepsAndOneWorld) {
  const Scene s = test::scene("falling-cubes", 10);
  Simulation sim(s);  // one territory: one world, on a thread of its own
  for (int k = 0; k <= 2000; ++k) {
    EXPECT_EQ(sim.step_at(k / 60.0), k);
    EXPECT_EQ(sim.step_at(k * (1.0 / 60.0)), k);
    EXPECT_EQ(sim.step_at(sim.time_of(k)), k);
    EXPECT_EQ(sim.step_at((k + 0.5) / 60.0), k);
  }
  EXPECT_THROW(sim.step_at(-0.1), std::invalid_argument);
  EXPECT_THROW(sim.step_at(std::nan("")), std::invalid_argument);
  ASSERT_TRUE(sim.advance_to(0.25));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(test::reference_hash(s, 15)));
}

// A heap on two territories with a pool of solver threads
// (docs/coloured-solve.md): the one-world hash, solved coloured.
TEST(Simulation, SolverThreadsKeepTheOneWorldHash) {
  const Scene s = test::scene("cube-pile", 200);
  SimulationConfig config;
  config.territories = 2;
  config.runtime.solver_threads = 2;
  Simulation sim(s, config);
  ASSERT_TRUE(sim.advance_to(sim.time_of(90)));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(test::reference_hash(s, 90)));
  EXPECT_GT(test::total(sim.metrics()).coloured_islands, 0u);
  EXPECT_EQ(test::total(sim.metrics()).solver_threads, 2);
}

// Interpolation between frames equals interpolate_entries on the
// reference's frames; at a step's own time it is the frame. try_read_at
// never waits; a frame the reader moved past is gone, its last one is not.
TEST(Simulation, InterpolatedAndNonBlockingReads) {
  const Scene s = test::scene("cube-pile", 80);
  constexpr int kN = 40;
  const test::Reference ref = test::reference_run(s, kN);
  Simulation sim(s, SimulationConfig{.territories = 4, .buffer_capacity = 64});
  SceneReader reader = sim.add_reader();  // before any step: it pins them all
  EXPECT_FALSE(reader.try_read_at(sim.time_of(1)).has_value());  // not published yet
  ASSERT_TRUE(sim.advance_to(sim.time_of(kN)));
  const double dt = s.settings.dt;
  auto entry = [&](int k) {
    TransformEntry<btScalar> e;
    e.step = k;
    e.time = sim.time_of(k);
    e.poses = ref.frames[static_cast<std::size_t>(k)];
    return e;
  };
  for (int k = 0; k < kN; ++k) {
    const std::optional<SceneSample> at = reader.interpolate(sim.time_of(k));
    ASSERT_TRUE(at.has_value());
    EXPECT_EQ(test::frame_difference(at->poses, ref.frames[static_cast<std::size_t>(k)]), "") << "step " << k;
    const double mid = (k + 0.3) * dt;
    const std::optional<SceneSample> between = reader.interpolate(mid);
    ASSERT_TRUE(between.has_value());
    EXPECT_EQ(between->before_step, k);
    EXPECT_EQ(between->after_step, k + 1);
    const SceneSample expected = interpolate_entries(entry(k), entry(k + 1), mid);
    EXPECT_EQ(test::frame_difference(between->poses, expected.poses), "") << "t " << mid;
  }
  // The reader is at step kN - 1: earlier steps are gone, its own is not.
  EXPECT_FALSE(reader.read_at(sim.time_of(3)).has_value());
  EXPECT_TRUE(reader.read_at(sim.time_of(kN - 1)).has_value());
  EXPECT_FALSE(reader.try_read_at(sim.time_of(kN + 1)).has_value());  // not published: no wait
  const std::optional<SceneFrame> last = reader.try_read_at(sim.time_of(kN) + 0.4 * dt);
  ASSERT_TRUE(last.has_value());
  EXPECT_EQ(last->step, kN);
  EXPECT_EQ(reader.last_step(), kN);
  ASSERT_NE(last->find(ref.frames[kN].front().id), nullptr);
  EXPECT_EQ(last->find(0xffffffffu), nullptr);
  sim.stop();
  // After the stop, reads serve what is held and never wait.
  EXPECT_FALSE(reader.read_at(sim.time_of(kN + 5)).has_value());
}

TEST(Simulation, BadConfigIsRejected) {
  const Scene s = test::scene("falling-cubes", 20);
  EXPECT_THROW(Simulation(s, SimulationConfig{.territories = 0}), std::invalid_argument);
  EXPECT_THROW(Simulation(s, SimulationConfig{.territories = 2, .threads = -1}), std::invalid_argument);
  EXPECT_THROW(Simulation(s, SimulationConfig{.territories = 2, .buffer_capacity = 1}), std::invalid_argument);
  EXPECT_THROW(Simulation(s, SimulationConfig{.territories = 2, .partition = "nonsense"}), GridError);
}

// A scene made in code is checked as a scene file is, before any world is
// built: SceneError naming the body or joint and the field, on one
// territory and on several (with a ready map too).
TEST(Simulation, AScenesMadeInCodeIsCheckedAsAFileIs) {
  auto refused = [](const Scene& s, const std::vector<std::string>& needles) {
    for (int k : {1, 3}) {
      try {
        Simulation sim(s, SimulationConfig{.territories = k});
        ADD_FAILURE() << "accepted on " << k;
      } catch (const SceneError& e) {
        std::printf("refused: %s\n", e.what());
        for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
      }
    }
  };
  Scene nan = test::scene("falling-cubes", 20);
  nan.bodies[5].position.x() = std::nan("");
  refused(nan, {"Simulation: scene", "(id " + std::to_string(nan.bodies[5].id) + ")", "'position'"});
  Scene twice = test::scene("falling-cubes", 20);
  twice.bodies[7].id = twice.bodies[6].id;
  refused(twice, {"duplicate id"});
  Scene joints = test::scene("pendulums", 4);
  joints.joints.push_back(joints.joints.front());
  refused(joints, {"joint #" + std::to_string(joints.joints.size() - 1), "duplicate joint id"});
  Scene missing = test::scene("pendulums", 4);
  missing.joints.front().body_b = 100000;
  refused(missing, {"'body_b'", "no body with id 100000"});
  const Scene ok = test::scene("falling-cubes", 20);
  EXPECT_THROW(Simulation(nan, make_partition("kmeans", ok, 2, GridOptions{})), SceneError);  // a ready map
}

}  // namespace
}  // namespace soda
