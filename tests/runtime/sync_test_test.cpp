// SyncTest (GGPO's check, PartitionedOptions::sync_test): after every step
// every world is rolled back a few steps — rebuilt from the whole scene's
// state kept in memory — and those steps are re-run; the state must come out
// bit-identical, and the run must still end on the one-territory hash. An
// event that happens only once (an injected fault) is caught as the
// difference it makes.
#include "runtime/partitioned_test_util.h"
#include "driver/testing_hooks.h"  // runtime/src: the test-only knobs

namespace soda {
namespace {

struct Case {
  const char* scene;
  int n;
  const char* partition;
  int territories;
  double cell = 0;  // > 0: cells of this size from the origin (borders at x = 0, z = 0)
  int steps = 120;
  int back = 3;
};

class SyncTest : public ::testing::TestWithParam<Case> {};

TEST_P(SyncTest, RollbacksReRunBitIdenticalAndTheRunMatchesOneWorld) {
  const Case c = GetParam();
  const Scene s = test::scene(c.scene, c.n);
  GridOptions grid;
  if (c.cell > 0) {
    grid.cell_size = c.cell;
    grid.origin = Vec3::Zero();
  }
  const TerritoryMap map = make_partition(c.partition, s, c.territories, grid);
  PartitionedWorld world(s, map, PartitionedOptions{.sync_test = c.back});
  world.step(c.steps);
  EXPECT_EQ(world.sync_rollbacks(), static_cast<std::uint64_t>(c.steps));
  EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(test::reference_hash(s, c.steps)));
  if (c.territories > 1) {
    EXPECT_GT(test::total(world.metrics()).ghosts_sent, 0u);
  }
  std::printf("[ sync-test %d: %s %s K=%d ] %d steps, %llu rollbacks re-run identical; %s\n", c.back, c.scene,
              c.partition, c.territories, c.steps, static_cast<unsigned long long>(world.sync_rollbacks()),
              hash_hex(world.state_hash()).c_str());
}

INSTANTIATE_TEST_SUITE_P(Runtime, SyncTest,
                         ::testing::Values(Case{"falling-cubes", 200, "kmeans", 1},
                                           Case{"falling-cubes", 200, "kmeans", 4},
                                           Case{"cube-pile", 200, "rcb", 3, 0, 120, 8},
                                           Case{"seam-stack", 0, "grid:2x1x2", 4, 2.0},
                                           Case{"cross-traffic", 0, "grid:2x1x2", 4, 2.0},
                                           Case{"projectile", 0, "kmeans", 8, 2.0, 150}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           std::string n = std::string(info.param.scene) + "_" + std::to_string(info.param.territories) +
                                           "_back" + std::to_string(info.param.back);
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

TEST(SyncTest, CatchesAnEventThatDoesNotHappenAgain) {
  // The injected fault fires once per run: the step it happened in comes out
  // differently when re-run, and SyncTest says so, naming the body.
  const Scene s = test::scene("cube-pile", 120);
  const TerritoryMap map = make_partition("kmeans", s, 2, GridOptions{});
  PartitionedOptions o{.sync_test = 2};
  o.runtime.watchdog.response = WatchdogResponse::Off;
  BodyId body = 0;
  for (const Body& b : s.bodies)
    if (!b.is_static) body = b.id;
  detail::edit_testing_hooks(o).inject_fault = {30, body};
  PartitionedWorld world(s, map, o);
  try {
    world.step(60);
    FAIL() << "SyncTest missed an event that happened only once";
  } catch (const std::logic_error& e) {
    std::printf("%s\n", e.what());
    EXPECT_NE(std::string(e.what()).find("step 30"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("body " + std::to_string(body)), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace soda
