// Fuzzing: 50 seeds of random pauses in every world's stages and in every
// message send (PartitionedOptions::fuzz_seed), over falling-cubes,
// cube-pile and the border scenes, on a thread per world and on a pool of
// two: threads interleave and messages from different worlds arrive in
// unusual orders, and every run still ends on the one-territory hash.
// Label "concurrency" (ThreadSanitizer in CI runs fewer seeds).
#include "runtime/partitioned_test_util.h"

#include <map>

namespace soda {
namespace {

#if defined(__SANITIZE_THREAD__)
constexpr int kSeeds = 12;
#else
constexpr int kSeeds = 50;
#endif
constexpr int kSteps = 60;

struct Case {
  const char* scene;
  int n;
  const char* partition;
  int territories;
  bool border_grid;
};

GridOptions grid_of(const Case& c) {
  GridOptions g;
  if (c.border_grid) {
    g.cell_size = 2.0;
    g.origin = Vec3::Zero();
    if (std::string(c.scene) == "chain") g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  }
  return g;
}

TEST(Fuzz, SeededPausesInThreadsAndMessagesNeverChangeTheResult) {
  const std::vector<Case> cases = {
      {"falling-cubes", 150, "kmeans", 4, false}, {"cube-pile", 150, "rcb", 3, false},
      {"seam-stack", 0, "grid:2x1x2", 4, true},   {"cross-traffic", 0, "grid:2x1x2", 4, true},
      {"projectile", 0, "kmeans", 8, true},       {"chain", 16, "grid:8x1x1", 8, true},
  };
  std::map<std::string, std::uint64_t> reference;
  for (const Case& c : cases) reference[c.scene] = test::reference_hash(test::scene(c.scene, c.n), kSteps);
  int pool_runs = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const Case& c = cases[static_cast<std::size_t>(seed) % cases.size()];
    const Scene s = test::scene(c.scene, c.n);
    const TerritoryMap map = make_partition(c.partition, s, c.territories, grid_of(c));
    PartitionedOptions o;
    o.schedule = seed % 2 ? Schedule::ThreadPerWorld : Schedule::Pool;
    o.threads = 2;
    o.fuzz_seed = static_cast<std::uint64_t>(seed);
    o.validate = true;
    pool_runs += o.schedule == Schedule::Pool;
    PartitionedWorld world(s, map, o);
    world.step(kSteps);
    EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(reference[c.scene]))
        << "seed " << seed << ": " << c.scene << " " << c.partition << " K=" << c.territories << " "
        << schedule_name(o.schedule);
  }
  EXPECT_GT(pool_runs, 0);
  std::printf("%d fuzzed runs (seeds 1..%d over %zu scenes, thread per world and pool) matched one territory\n",
              kSeeds, kSeeds, cases.size());
}

}  // namespace
}  // namespace soda
