// Substeps per island (worlds/src/island_substeps.h, docs/stress.md
// "Dense-pile-1000"): islands of boxes whose touching bodies move fast
// against their size are solved in substeps inside the solve stage. The
// choice reads only the island's contents, so cube-pile (whose landing
// heap triggers it, as a local island and as a merged border island) keeps
// the one-world hash with K = 1, 2, 4 territories, anticipation 8 and under
// SyncTest, and the substeps really ran (the metrics' counter). Label
// "concurrency".
#include <gtest/gtest.h>

#include <cstdio>

#include "runtime/partitioned_test_util.h"

namespace soda {
namespace {

constexpr int kBodies = 150;
constexpr int kSteps = 120;

TEST(IslandSubsteps, CubePileOneHashForEveryTerritoryCount) {
  const Scene s = test::scene("cube-pile", kBodies);
  CanonicalWorld one(s);
  std::uint64_t substepped = 0;
  for (int i = 0; i < kSteps; ++i) {
    one.step();
    substepped += one.last_step_stats().substepped_islands;
  }
  const std::uint64_t reference = one.state_hash();
  EXPECT_GT(substepped, 0u) << "no island was solved in substeps";
  for (int k : {1, 2, 4}) {
    PartitionedOptions o;
    o.schedule = Schedule::ThreadPerWorld;
    o.runtime.anticipation = 8;
    PartitionedWorld w(s, make_partition("kmeans", s, k, GridOptions{}), o);
    w.step(kSteps);
    const WorldMetrics t = test::total(w.metrics());
    std::printf("[ cube-pile %d %s K=%d ] %s (one world %s), %llu substepped islands (one world %llu), %llu "
                "border islands\n",
                kBodies, kPrecisionName, k, hash_hex(w.state_hash()).c_str(), hash_hex(reference).c_str(),
                static_cast<unsigned long long>(t.substepped_islands), static_cast<unsigned long long>(substepped),
                static_cast<unsigned long long>(t.islands_solved));
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference)) << "K=" << k;
    EXPECT_GT(t.substepped_islands, 0u) << "K=" << k;
    if (k > 1) {
      EXPECT_GT(t.islands_solved, 0u) << "K=" << k << ": no border island";
    }
  }
}

TEST(IslandSubsteps, CubePileSyncTest) {
#if defined(__SANITIZE_THREAD__)  // TSan looks for races: a shorter run (28 s of CI's TSan step at 120)
  constexpr int kSyncSteps = 40;
#else
  constexpr int kSyncSteps = kSteps;
#endif
  const Scene s = test::scene("cube-pile", kBodies);
  PartitionedOptions o;
  o.sync_test = 8;
  PartitionedWorld w(s, make_partition("kmeans", s, 2, GridOptions{}), o);
  w.step(kSyncSteps);
  EXPECT_EQ(w.sync_rollbacks(), static_cast<std::uint64_t>(kSyncSteps));
  EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(test::reference_hash(s, kSyncSteps)));
  EXPECT_GT(test::total(w.metrics()).substepped_islands, 0u);
}

}  // namespace
}  // namespace soda
