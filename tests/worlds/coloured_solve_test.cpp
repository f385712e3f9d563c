// The coloured solve of large islands (docs/coloured-solve.md): it runs on
// a heap, its result does not depend on the number of solver threads nor on
// the insertion order, and a pool really gives its threads to the solve.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <vector>

#include "soda/worlds/canonical_world.h"
#include "soda/worlds/solver_pool.h"
#include "worlds/world_test_util.h"

namespace soda {
namespace {

constexpr int kPileBodies = 300;
constexpr int kPileSteps = 200;

struct PileRun {
  std::uint64_t hash = 0;
  std::size_t coloured_islands = 0;  // summed over steps
  int solver_threads = 0;
};

PileRun run_pile(int solver_threads, const std::vector<std::size_t>& order = {}) {
  const Scene scene = test::scene("cube-pile", kPileBodies);
  CanonicalWorld w(scene, order);
  if (solver_threads > 1) w.set_solver_pool(std::make_shared<SolverPool>(solver_threads));
  PileRun r;
  for (int s = 0; s < kPileSteps; ++s) {
    w.step();
    r.coloured_islands += w.last_step_stats().coloured_islands;
  }
  r.hash = w.state_hash(true);
  r.solver_threads = w.last_step_stats().solver_threads;
  return r;
}

TEST(ColouredSolve, SameBitsForAnyNumberOfSolverThreads) {
  const PileRun one = run_pile(1);
  std::printf("[ cube-pile %d %s ] 1 solver thread: %s, %zu coloured islands\n", kPileBodies, kPrecisionName,
              hash_hex(one.hash).c_str(), one.coloured_islands);
  // The heap is one island far above kColouredMinContactRows for most steps.
  EXPECT_GT(one.coloured_islands, static_cast<std::size_t>(kPileSteps / 2));
  EXPECT_EQ(one.solver_threads, 1);
  for (int threads : {2, 3, 8}) {
    const PileRun r = run_pile(threads);
    std::printf("[ cube-pile %d %s ] %d solver threads: %s, %zu coloured islands\n", kPileBodies, kPrecisionName,
                threads, hash_hex(r.hash).c_str(), r.coloured_islands);
    EXPECT_EQ(hash_hex(r.hash), hash_hex(one.hash)) << threads << " solver threads";
    EXPECT_EQ(r.coloured_islands, one.coloured_islands);
    EXPECT_EQ(r.solver_threads, threads) << "the coloured solve did not get the pool's threads";
  }
}

TEST(ColouredSolve, InsertionOrderFreeWithThreads) {
  const PileRun a = run_pile(1);
  const PileRun b = run_pile(3, test::shuffled_order(test::scene("cube-pile", kPileBodies).bodies.size(), 7));
  EXPECT_EQ(hash_hex(a.hash), hash_hex(b.hash));
}

TEST(SolverPool, RunsEveryTaskOnceOnItsThreads) {
  SolverPool pool(3);
  EXPECT_EQ(pool.threads(), 3);
  for (int round = 0; round < 200; ++round) {
    const int count = 1 + round % 37;
    std::vector<std::atomic<int>> hits(static_cast<std::size_t>(count));
    const int threads = pool.run(count, [&](int i) { hits[static_cast<std::size_t>(i)].fetch_add(1); });
    EXPECT_EQ(threads, count > 1 ? 3 : 1);
    for (const auto& h : hits) ASSERT_EQ(h.load(), 1);
  }
  EXPECT_THROW(SolverPool(0), std::invalid_argument);
}

TEST(SolverPool, BusyPoolRunsTheSecondCallerAlone) {
  SolverPool pool(2);
  std::atomic<bool> inside{false}, release{false};
  std::atomic<int> second_threads{0};
  std::thread first([&] {
    pool.run(2, [&](int) {
      inside = true;
      while (!release) std::this_thread::yield();
    });
  });
  while (!inside) std::this_thread::yield();
  int done = 0;
  second_threads = pool.run(4, [&](int) { ++done; });
  release = true;
  first.join();
  EXPECT_EQ(second_threads.load(), 1);
  EXPECT_EQ(done, 4);
}

}  // namespace
}  // namespace soda
