// PartitionedWorld over MPI ranks (docs/mpi.md): run by ctest under
// `mpirun -np 2` and `-np 4` (label mpi). Every rank runs every test in the
// same order (the runs and their gathers are collective); rank 0 compares
// the gathered whole-scene hash with the one-world reference. The suite
// has its own main: MPI is initialised before GoogleTest runs.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "../runtime/partitioned_test_util.h"
#include "soda/mpi/mpi_group.h"
#include "soda/mpi/mpi_session.h"
#include "soda/worlds/watchdog.h"
#include "testing_hooks.h"

namespace soda {
namespace {

std::shared_ptr<ProcessGroup> g_group;  // every test's; made once in main

struct Case {
  std::string scene;
  int n = 0;
  std::string partition = "kmeans";
  int territories = 2;
  int steps = 60;
  bool border_grid = false;
};

// The partitioned run over the ranks; rank 0 checks its gathered hash
// against the one-world run (also the threaded 1-territory run's hash).
void expect_reference_hash(const Case& c, PartitionedOptions options = {}) {
  const Scene s = test::scene(c.scene, c.n);
  const TerritoryMap map =
      make_partition(c.partition, s, c.territories, c.border_grid ? test::border_grid() : GridOptions{});
  options.group = g_group;
  PartitionedWorld world(s, map, options);
  world.step(c.steps);
  const std::uint64_t hash = world.state_hash();  // collective
  const std::size_t bodies = world.body_count();  // collective
  if (g_group->rank() != 0) return;
  EXPECT_EQ(bodies, s.bodies.size());
  const std::uint64_t reference = test::reference_hash(s, c.steps);
  EXPECT_EQ(hash, reference) << c.scene << " " << c.partition << " K=" << c.territories << " on "
                             << g_group->size() << " ranks: " << hash_hex(hash) << " vs one world "
                             << hash_hex(reference);
}

PartitionedOptions threads_per_world() {
  PartitionedOptions o;
  o.schedule = Schedule::ThreadPerWorld;
  return o;
}

TEST(Mpi, FallingCubesGiveTheOneWorldHash) {
  expect_reference_hash({"falling-cubes", 150, "kmeans", 2, 60}, threads_per_world());
  expect_reference_hash({"falling-cubes", 150, "kmeans", 4, 60}, threads_per_world());
}

TEST(Mpi, CubePileGivesTheOneWorldHash) {
  expect_reference_hash({"cube-pile", 100, "kmeans", 4, 60}, threads_per_world());
}

TEST(Mpi, BorderScenesGiveTheOneWorldHash) {
  // Towers on the plane x = 0 and on the corner where four territories meet.
  expect_reference_hash({"seam-stack", 0, "grid:2x1x2", 4, 120, true}, threads_per_world());
  // Spheres shuttling across three borders: migrations between ranks.
  expect_reference_hash({"border-shuttle", 40, "grid:4x1x1", 4, 80}, threads_per_world());
}

TEST(Mpi, MoreTerritoriesThanRanksOnAPoolOrOneThread) {
  PartitionedOptions pool;
  pool.schedule = Schedule::Pool;
  pool.threads = 2;
  expect_reference_hash({"falling-cubes", 150, "kmeans", 6, 50}, pool);
  PartitionedOptions one;  // Sequential: one pool worker per rank
  one.schedule = Schedule::Sequential;
  expect_reference_hash({"falling-cubes", 150, "kmeans", 5, 50}, one);
}

TEST(Mpi, SerialisedAndFuzzedMessagesGiveTheOneWorldHash) {
  PartitionedOptions o = threads_per_world();
  o.serialise = true;
  detail::edit_testing_hooks(o).fuzz_seed = 11;
  expect_reference_hash({"cube-pile", 80, "kmeans", 4, 40}, o);
}

TEST(Mpi, SpeculationIsRefusedWithAClearError) {
  const Scene s = test::scene("falling-cubes", 50);
  const TerritoryMap map = make_partition("kmeans", s, 2, GridOptions{});
  PartitionedOptions o;
  o.anticipation = 8;
  o.group = g_group;
  try {
    PartitionedWorld world(s, map, o);
    FAIL() << "expected speculation over ranks to be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("speculation"), std::string::npos) << e.what();
  }
}

// A world that throws on one rank stops the run on every rank, each with the
// failing world's error; nobody hangs (ctest's timeout would say so).
TEST(Mpi, AFailingRankStopsEveryRankWithItsError) {
  const Scene s = test::scene("cube-pile", 100);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  PartitionedOptions o = threads_per_world();
  o.watchdog.response = WatchdogResponse::Stop;
  o.group = g_group;
  // A body of the world on the last rank: its rank fails, the others are told.
  BodyId body = 0;
  const WorldId w = 3;
  for (const Body& b : s.bodies)
    if (!b.is_static && map.owner_of(b.position) == w) body = b.id;
  ASSERT_NE(body, 0);
  detail::edit_testing_hooks(o).inject_fault = {10, body};
  PartitionedWorld world(s, map, o);
  try {
    world.step(40);
    ADD_FAILURE() << "rank " << g_group->rank() << ": expected the run to stop with world " << w << "'s error";
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("watchdog: step 10"), std::string::npos) << "rank " << g_group->rank() << ": " << what;
    if (g_group->rank_of(w, 4) != g_group->rank()) {
      EXPECT_NE(what.find("rank " + std::to_string(g_group->rank_of(w, 4)) + " failed: world 3"), std::string::npos)
          << what;
    }
  }
}

}  // namespace
}  // namespace soda

int main(int argc, char** argv) {
  soda::MpiSession mpi(&argc, &argv);
  testing::InitGoogleTest(&argc, argv);
  soda::g_group = soda::make_mpi_group();
  // Every rank reports (a failure on rank 1 is printed by rank 1); mpirun
  // fails the job if any rank returns non-zero.
  const int failed = RUN_ALL_TESTS();
  soda::g_group.reset();
  return failed;
}
