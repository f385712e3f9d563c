// Schedules: one thread per world, and a pool of fewer threads than worlds,
// give the hashes of the sequential round-robin driver and of one world —
// run under ThreadSanitizer in CI (label "concurrency"). Errors in one world
// stop every world and reach the caller.
#include <gtest/gtest.h>

#include <thread>

#include "runtime/partitioned_test_util.h"
#include "soda/runtime/transport.h"

namespace soda {
namespace {

constexpr int kSteps = 150;

struct RunOutcome {
  std::uint64_t hash;
  WorldMetrics total;
};

RunOutcome run(const Scene& s, const TerritoryMap& map, PartitionedOptions o) {
  PartitionedWorld w(s, map, o);
  w.step(kSteps);
  return RunOutcome{w.state_hash(), test::total(w.metrics())};
}

void expect_schedules_agree(const std::string& scene, int n, const std::string& partition, int k) {
  const Scene s = test::scene(scene, n);
  const TerritoryMap map = make_partition(partition, s, k, GridOptions{});
  const std::uint64_t reference = test::reference_hash(s, kSteps);
  const RunOutcome sequential = run(s, map, {});
  const RunOutcome per_world = run(s, map, {.schedule = Schedule::ThreadPerWorld});
  const RunOutcome pool2 = run(s, map, {.schedule = Schedule::Pool, .threads = 2});
  const RunOutcome pool3 = run(s, map, {.schedule = Schedule::Pool, .threads = 3, .runtime = {.validate = true}});
  std::printf("[ %s %s %s K=%d ] one world %s; sequential %s, thread per world %s (blocked %.3f s), pool of 2 %s, "
              "pool of 3 + validation %s; %s\n",
              scene.c_str(), kPrecisionName, partition.c_str(), k, hash_hex(reference).c_str(),
              hash_hex(sequential.hash).c_str(), hash_hex(per_world.hash).c_str(), per_world.total.blocked_seconds,
              hash_hex(pool2.hash).c_str(), hash_hex(pool3.hash).c_str(), test::summary(per_world.total).c_str());
  EXPECT_EQ(hash_hex(sequential.hash), hash_hex(reference));
  EXPECT_EQ(hash_hex(per_world.hash), hash_hex(reference));
  EXPECT_EQ(hash_hex(pool2.hash), hash_hex(reference));
  EXPECT_EQ(hash_hex(pool3.hash), hash_hex(reference));
  EXPECT_GT(per_world.total.merged_islands, 0u);
  EXPECT_GT(per_world.total.migrations_out, 0u);
}

TEST(Schedules, CubePileFourWorlds) { expect_schedules_agree("cube-pile", 120, "kmeans", 4); }
TEST(Schedules, FallingCubesEightWorlds) { expect_schedules_agree("falling-cubes", 150, "rcb", 8); }

TEST(Schedules, ChainAcrossEightWorldsOnThreads) {
  const Scene s = test::scene("chain", 16);
  GridOptions g;
  g.cell_size = 2.0;
  g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  const TerritoryMap map = make_partition("grid:8x1x1", s, 8, g);
  const std::uint64_t reference = test::reference_hash(s, kSteps);
  for (PartitionedOptions o : {PartitionedOptions{.schedule = Schedule::ThreadPerWorld},
                               PartitionedOptions{.schedule = Schedule::Pool, .threads = 2}}) {
    const RunOutcome r = run(s, map, o);
    std::printf("[ chain %s grid:8x1x1 %s ] one world %s, partitioned %s, island over %llu worlds\n", kPrecisionName,
                schedule_name(o.schedule), hash_hex(reference).c_str(), hash_hex(r.hash).c_str(),
                static_cast<unsigned long long>(r.total.merged_island_worlds_max));
    EXPECT_EQ(hash_hex(r.hash), hash_hex(reference));
    EXPECT_EQ(r.total.merged_island_worlds_max, 8u);
  }
}

// A body faster than the run's reach (neighbourhoods sized for 3 m/s, the
// chain's push: its halo reaches a world that is not a neighbour) fails
// loudly in its world; every schedule stops and reports it instead of
// hanging.
TEST(Schedules, AnErrorInOneWorldStopsEveryWorld) {
  Scene s = test::scene("chain", 16);
  for (Body& b : s.bodies)
    if (b.id == 9) b.linear_velocity = Vec3(400.0, 0.0, 0.0);  // ~6.7 m per step, cells are 2 m
  GridOptions g;
  g.cell_size = 2.0;
  g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  const TerritoryMap map = make_partition("grid:8x1x1", s, 8, g);
  for (PartitionedOptions o : {PartitionedOptions{.runtime = {.reach_speed = 3}},
                               PartitionedOptions{.schedule = Schedule::ThreadPerWorld, .runtime = {.reach_speed = 3}},
                               PartitionedOptions{.schedule = Schedule::Pool, .threads = 3, .runtime = {.reach_speed = 3}}}) {
    PartitionedWorld w(s, map, o);
    try {
      w.step(20);
      ADD_FAILURE() << "no exception with " << schedule_name(o.schedule);
    } catch (const PartitionError& e) {
      std::printf("[ %s ] %s\n", schedule_name(o.schedule), e.what());
      EXPECT_NE(std::string(e.what()).find("body 9"), std::string::npos);
    }
  }
}

TEST(Transport, BlockingReceiveWakesAndCloseReleases) {
  for (bool serialise : {false, true}) {
    auto t = serialise ? make_serialising_transport(2) : make_in_memory_transport(2);
    std::thread receiver([&] {
      for (int i = 0; i < 100; ++i) {
        const Message m = t->receive(1);
        EXPECT_EQ(m.step, i);
      }
      EXPECT_THROW(t->receive(1), TransportClosed);
    });
    for (int i = 0; i < 100; ++i) t->send(1, Message{0, 1, i, GlueBatch{}});
    while (t->try_receive(0)) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    t->close();
    receiver.join();
  }
}

}  // namespace
}  // namespace soda
