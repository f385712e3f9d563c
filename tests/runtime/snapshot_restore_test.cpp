// Restoring the whole scene's state: a partitioned run's snapshot at a step
// boundary equals the one-world run's (bodies and contact state, bit for
// bit), and worlds rebuilt from it — K territories under any map, or one
// CanonicalWorld — continue exactly as the uninterrupted run. This is what
// rollback (watchdog self-heal, user input at a past step) rests on.
#include "runtime/partitioned_test_util.h"

#include "soda/worlds/world_snapshot.h"

namespace soda {
namespace {

constexpr int kBodies = 250;
constexpr int kBefore = 150;
constexpr int kAfter = 150;

struct Case {
  const char* scene;
  const char* partition;  // the run the snapshot is taken from
  int territories;
  const char* restore_partition;  // the worlds rebuilt from it
  int restore_territories;
  int bodies = kBodies;           // 0: the scene's default
  bool border_grid = false;       // 2 m cells from the origin: borders at x = 0, z = 0
};

GridOptions grid_of(const Case& c) {
  GridOptions g;
  if (c.border_grid) {
    g.cell_size = 2.0;
    g.origin = Vec3::Zero();
  }
  return g;
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string s = std::string(info.param.scene) + "_" + info.param.partition + "_" +
                  std::to_string(info.param.territories) + "_to_" + info.param.restore_partition + "_" +
                  std::to_string(info.param.restore_territories);
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

class SnapshotRestore : public ::testing::TestWithParam<Case> {};

TEST_P(SnapshotRestore, ContinuesAsTheUninterruptedRun) {
  const Case c = GetParam();
  const Scene s = test::scene(c.scene, c.bodies);
  CanonicalWorld reference(s);
  for (int i = 0; i < kBefore; ++i) reference.step();
  const WorldSnapshot at = reference.snapshot();

  const TerritoryMap map = make_partition(c.partition, s, c.territories, grid_of(c));
  PartitionedWorld run(s, map, PartitionedOptions{.runtime = {.validate = true}});
  run.step(kBefore);
  const WorldSnapshot part = run.snapshot();
  ASSERT_EQ(part.steps_done, kBefore);
  ASSERT_EQ(part.bodies.size(), at.bodies.size());
  // The mechanism under test: there is contact state to carry over.
  ASSERT_GT(at.manifolds.size(), 10u);
  EXPECT_EQ(part.manifolds.size(), at.manifolds.size());
  EXPECT_EQ(hash_hex(contact_hash(part.manifolds)), hash_hex(contact_hash(at.manifolds)));
  EXPECT_EQ(hash_hex(run.state_hash()), hash_hex(reference.state_hash()));

  for (int i = 0; i < kAfter; ++i) reference.step();
  const std::uint64_t expected = reference.state_hash();

  // The partitioned snapshot, restored onto another map.
  const TerritoryMap other = make_partition(c.restore_partition, s, c.restore_territories, grid_of(c));
  PartitionedWorld restored(part, other, PartitionedOptions{.runtime = {.validate = true}});
  EXPECT_EQ(restored.steps_done(), kBefore);
  restored.step(kAfter);
  EXPECT_EQ(hash_hex(restored.state_hash()), hash_hex(expected));
  EXPECT_GT(test::total(restored.metrics()).manifolds_seeded, 0u);

  // The partitioned snapshot in one CanonicalWorld.
  CanonicalWorld one(part);
  for (int i = 0; i < kAfter; ++i) one.step();
  EXPECT_EQ(hash_hex(one.state_hash()), hash_hex(expected));

  // The one-world snapshot on K territories.
  PartitionedWorld from_one(at, map, PartitionedOptions{.runtime = {.validate = true}});
  from_one.step(kAfter);
  EXPECT_EQ(hash_hex(from_one.state_hash()), hash_hex(expected));
  std::printf("[ %s %s %s K=%d -> %s K=%d ] %zu manifolds carried; %s\n", c.scene, kPrecisionName, c.partition,
              c.territories, c.restore_partition, c.restore_territories, part.manifolds.size(),
              hash_hex(expected).c_str());
}

INSTANTIATE_TEST_SUITE_P(Runtime, SnapshotRestore,
                         ::testing::Values(Case{"falling-cubes", "kmeans", 4, "rcb", 3},
                                           Case{"cube-pile", "kmeans", 4, "grid:2x1x2", 4},
                                           Case{"cube-pile", "rcb", 8, "kmeans", 1},
                                           Case{"seam-stack", "grid:2x1x1", 2, "grid:2x1x2", 4, 0, true}),
                         case_name);

// The restored run keeps going through more restores: snapshot and rebuild
// every 40 steps (as a rollback would), still the uninterrupted result.
TEST(SnapshotRestore, RepeatedRestoresMatchTheUninterruptedRun) {
  const Scene s = test::scene("cube-pile", kBodies);
  const TerritoryMap map = make_partition("kmeans", s, 3, GridOptions{});
  auto run = std::make_unique<PartitionedWorld>(s, map);
  for (int round = 0; round < 6; ++round) {
    run->step(40);
    const WorldSnapshot at = run->snapshot();
    run = std::make_unique<PartitionedWorld>(at, map);
  }
  EXPECT_EQ(run->steps_done(), 240);
  EXPECT_EQ(hash_hex(run->state_hash()), hash_hex(test::reference_hash(s, 240)));
}

}  // namespace
}  // namespace soda
