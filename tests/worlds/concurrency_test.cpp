// Several canonical worlds stepping at once on several threads give the same
// hashes as the same worlds stepped one after the other: a world shares no
// writable state with another (docs/bullet-globals.md).
#include <gtest/gtest.h>

#include <cstdio>
#include <thread>

#include "soda/worlds/canonical_world.h"
#include "worlds/world_test_util.h"

namespace soda {
namespace {

TEST(CanonicalWorldThreads, ConcurrentWorldsMatchSequential) {
  constexpr int kWorlds = 4;
  constexpr int kSteps = 300;
  std::vector<Scene> scenes;
  for (int i = 0; i < kWorlds; ++i)
    scenes.push_back(test::scene(i % 2 ? "falling-cubes" : "cube-pile", 200, static_cast<std::uint64_t>(i + 1)));
  std::vector<std::uint64_t> sequential(kWorlds), concurrent(kWorlds);
  for (int i = 0; i < kWorlds; ++i) {
    CanonicalWorld w(scenes[i]);
    test::run(w, kSteps);
    sequential[i] = w.state_hash(true);
  }
  std::vector<std::thread> threads;
  for (int i = 0; i < kWorlds; ++i)
    threads.emplace_back([&, i] {
      CanonicalWorld w(scenes[i], test::shuffled_order(scenes[i].bodies.size(), 100 + i));
      test::run(w, kSteps);
      concurrent[i] = w.state_hash(true);
    });
  for (std::thread& t : threads) t.join();
  for (int i = 0; i < kWorlds; ++i) {
    std::printf("[ world %d %s ] sequential %s, on a thread %s\n", i, kPrecisionName,
                hash_hex(sequential[i]).c_str(), hash_hex(concurrent[i]).c_str());
    EXPECT_EQ(hash_hex(sequential[i]), hash_hex(concurrent[i]));
  }
}

}  // namespace
}  // namespace soda
