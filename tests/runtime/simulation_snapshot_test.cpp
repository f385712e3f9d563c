// Simulation snapshots (docs/embedding.md, "Snapshots"): a snapshot taken
// from a Simulation that has run for a while, with bodies added and removed
// and inputs still queued, restored with another number of territories,
// schedule and speculation, goes on to the uninterrupted run's state hash;
// restored ids are never reused. Label "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "runtime/simulation_test_util.h"

namespace soda {
namespace {

constexpr int kSnapshotAt = 60;
constexpr int kSteps = 150;

using test::first_dynamic;
using test::new_cube;
using test::unused_id;

struct Inputs {
  BodyId added = 0, removed = 0, pushed = 0;
};

// Inputs before the snapshot (an add, a removal) and after it (queued: an
// impulse at 100 on the added body).
Inputs give_inputs(Simulation& sim, const Scene& s) {
  Inputs in;
  in.added = unused_id(s);
  in.removed = first_dynamic(s);
  in.pushed = in.added;
  sim.add_body(sim.time_of(20), new_cube(in.added, Vec3(0.2, 10, -0.1)));
  sim.remove_body(sim.time_of(40), in.removed);
  sim.apply_impulse(sim.time_of(100), in.pushed, Vec3(1, 6, 0));
  return in;
}

struct Case {
  int territories;
  int threads;
  int anticipation;
};

class SimulationSnapshotRestore : public ::testing::TestWithParam<Case> {};

TEST_P(SimulationSnapshotRestore, GoesOnToTheUninterruptedHash) {
  const Case c = GetParam();
  const Scene s = test::scene("cube-pile", 150);
  // The uninterrupted run: 2 territories, lockstep.
  Simulation a(s, SimulationConfig{.territories = 2});
  const Inputs in = give_inputs(a, s);
  ASSERT_TRUE(a.advance_to(a.time_of(kSnapshotAt)));
  const SimulationSnapshot snap = a.snapshot();
  ASSERT_TRUE(a.advance_to(a.time_of(kSteps)));
  const std::uint64_t uninterrupted = a.state_hash();

  SimulationConfig config{.territories = c.territories, .threads = c.threads, .buffer_capacity = 16};
  config.runtime.anticipation = c.anticipation;
  Simulation b(snap, config);
  EXPECT_EQ(b.steps_done(), kSnapshotAt);
  EXPECT_EQ(b.published_step(), kSnapshotAt);
  {
    SceneReader reader = b.add_reader();  // destroyed before the run: it would hold the worlds back
    std::optional<SceneFrame> first = reader.read_at(b.time_of(kSnapshotAt));
    ASSERT_TRUE(first.has_value());
    EXPECT_EQ(first->step, kSnapshotAt);
    EXPECT_EQ(first->find(in.removed), nullptr);
    EXPECT_NE(first->find(in.added), nullptr);
  }
  ASSERT_TRUE(b.advance_to(b.time_of(kSteps)));
  const std::uint64_t restored = b.state_hash();
  std::printf("[ cube-pile 150, snapshot at %d: %zu bodies, %zu manifolds, %zu queued inputs ] K 2 uninterrupted %s, "
              "restored on K %d threads %d anticipation %d %s\n",
              kSnapshotAt, snap.state.bodies.size(), snap.state.manifolds.size(), snap.inputs.size(),
              hash_hex(uninterrupted).c_str(), c.territories, c.threads, c.anticipation, hash_hex(restored).c_str());
  EXPECT_EQ(hash_hex(restored), hash_hex(uninterrupted));
  EXPECT_EQ(snap.inputs.size(), 1u);  // the impulse at 100
  ASSERT_EQ(snap.retired_ids.size(), 1u);
  EXPECT_EQ(snap.retired_ids[0], in.removed);
  // The removed body's id stays retired: neither reusable nor nameable.
  EXPECT_THROW(b.add_body(b.time_of(kSteps + 1), new_cube(in.removed, Vec3(0, 12, 0))), std::invalid_argument);
  EXPECT_THROW(b.apply_impulse(b.time_of(kSteps + 1), in.removed, Vec3(0, 1, 0)), std::invalid_argument);
}

INSTANTIATE_TEST_SUITE_P(Simulation, SimulationSnapshotRestore,
                         ::testing::Values(Case{1, 1, 0}, Case{4, 0, 0}, Case{8, 0, 8}, Case{4, 2, 8}),
                         [](const auto& info) {
                           return "K" + std::to_string(info.param.territories) + "_threads" +
                                  std::to_string(info.param.threads) + "_anticipation" +
                                  std::to_string(info.param.anticipation);
                         });

// A snapshot of a Simulation that runs freely (start with an end time) is
// taken once its worlds are parked there.
TEST(SimulationSnapshot, OfARunningSimulationIsTakenAtItsStepLimit) {
  const Scene s = test::scene("falling-cubes", 120);
  Simulation a(s, SimulationConfig{.territories = 4});
  a.start(a.time_of(50));
  const SimulationSnapshot snap = a.snapshot();
  EXPECT_EQ(snap.state.steps_done, 50);
  EXPECT_EQ(hash_hex(CanonicalWorld(snap.state).state_hash()), hash_hex(a.state_hash()));
  a.stop();
  Simulation b(snap, SimulationConfig{.threads = 1});
  EXPECT_EQ(hash_hex(b.state_hash()), hash_hex(a.state_hash()));
}

}  // namespace
}  // namespace soda
