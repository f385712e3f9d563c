// Fuzzing: 50 seeds of random pauses in every world's stages and in every
// message send (detail::TestingHooks::fuzz_seed), over falling-cubes,
// cube-pile and the border scenes, on a thread per world and on a pool of
// two: threads interleave and messages from different worlds arrive in
// unusual orders, and every run still ends on the one-territory hash.
// Label "concurrency" (ThreadSanitizer in CI runs fewer seeds).
#include "runtime/partitioned_test_util.h"
#include "driver/testing_hooks.h"  // runtime/src: the test-only knobs

#include <map>

namespace soda {
namespace {

#if defined(__SANITIZE_THREAD__)
constexpr int kSeeds = 12;
#else
constexpr int kSeeds = 50;
#endif
constexpr int kSteps = 60;

TEST(Fuzz, SeededPausesInThreadsAndMessagesNeverChangeTheResult) {
  const std::vector<test::Case>& cases = test::mixed_cases();
  std::map<std::string, std::uint64_t> reference;
  for (const test::Case& c : cases) reference[c.scene] = test::reference_hash(test::scene(c.scene, c.n), kSteps);
  int pool_runs = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const test::Case& c = cases[static_cast<std::size_t>(seed) % cases.size()];
    const Scene s = test::scene(c.scene, c.n);
    const TerritoryMap map = test::map_of(c, s);
    PartitionedOptions o;
    o.schedule = seed % 2 ? Schedule::ThreadPerWorld : Schedule::Pool;
    o.threads = 2;
    detail::edit_testing_hooks(o).fuzz_seed = static_cast<std::uint64_t>(seed);
    o.runtime.validate = true;
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
