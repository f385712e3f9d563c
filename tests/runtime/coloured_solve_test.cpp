// The coloured solve of large islands across territories
// (docs/coloured-solve.md, #16 acceptance 1): a heap solved as a local
// island (one territory) or as a merged border island (several) gives the
// one-world hash for every territory count (1, 2, 3, 4, 8), every number of
// solver threads (1, 2, 3, 8), every schedule, with anticipation 8, under
// SyncTest and under the fuzzer; the coloured path really ran, on the
// pool's threads. The border scenes and falling-cubes (small islands, not
// coloured) keep the one-world hash with solver threads too. Label
// "concurrency".
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "parallel_stages.h"  // worlds/src: kParallelMinBodies
#include "runtime/partitioned_test_util.h"
#include "soda/worlds/solver_pool.h"
#include "driver/testing_hooks.h"  // runtime/src: the test-only knobs

namespace soda {
namespace {

// cube-pile 150 lands at about step 90 and is then one island of 256+
// contact rows (about 60 coloured solves in 150 steps).
constexpr int kBodies = 150;
constexpr int kSteps = 150;
constexpr int kMinColoured = 40;

struct Outcome {
  std::uint64_t hash;
  WorldMetrics total;
};

Outcome run(const Scene& s, const TerritoryMap& map, const PartitionedOptions& o) {
  PartitionedWorld w(s, map, o);
  w.step(kSteps);
  return Outcome{w.state_hash(), test::total(w.metrics())};
}

// The heap is coloured, on the pool's `threads` threads and up to `guests`
// more; with K > 1 it is a merged border island solved at a root. A pool
// of one thread with guest slots has someone to share a job with only
// while a guest is inside (SolverPool::run): whether one ever was is a
// matter of timing (under load at K = 2, often never in 150 steps), so the
// guests' slots are a range here and their work is checked over all runs.
void expect_coloured(const Outcome& r, int k, int threads, int guests = 0) {
  EXPECT_GT(r.total.coloured_islands, static_cast<std::uint64_t>(kMinColoured)) << "the heap was not solved coloured";
  if (threads > 1 || guests == 0) {
    EXPECT_EQ(r.total.solver_threads, threads + guests) << "the coloured solve did not get the pool's threads";
  } else {
    EXPECT_GE(r.total.solver_threads, 1) << "the coloured solve did not run";
    EXPECT_LE(r.total.solver_threads, threads + guests) << "the coloured solve counted more threads than slots";
  }
  if (k > 1) {
    EXPECT_GT(r.total.islands_solved, 0u);
    // The root solves its own share in place and the others' on copies.
    EXPECT_GT(r.total.merged_island_bodies_in_place, 0u) << "no root solved its own bodies in place";
    EXPECT_LT(r.total.merged_island_bodies_in_place, r.total.merged_island_bodies)
        << "every merged island's bodies were the root's own";
  }
}

TEST(ColouredSolve, CubePileEveryTerritoryCountAndSolverThreadCount) {
  const Scene s = test::scene("cube-pile", kBodies);
  const std::uint64_t reference = test::reference_hash(s, kSteps);
  const Schedule schedules[] = {Schedule::Sequential, Schedule::ThreadPerWorld, Schedule::Pool};
#if defined(__SANITIZE_THREAD__)  // TSan looks for races: fewer, slower runs (each schedule once)
  const std::vector<int> ks = {1, 3, 8}, solver_threads = {3};
#else
  const std::vector<int> ks = {1, 2, 3, 4, 8}, solver_threads = {1, 2, 3, 8};
#endif
  int i = 0;
  for (int k : ks) {
    const TerritoryMap map = make_partition("kmeans", s, k, GridOptions{});
    for (int threads : solver_threads) {
      PartitionedOptions o;
      o.schedule = schedules[i % 3];
      o.threads = 2;
      o.runtime.anticipation = i % 2 ? 8 : 0;
      o.runtime.solver_threads = threads;
      // A waiting world's thread as a guest of the pool: explicit, so that
      // the threads counted below do not depend on the machine's cores.
      o.runtime.solver_guests = o.schedule == Schedule::ThreadPerWorld && k > 1 ? 1 : 0;
      ++i;
      const Outcome r = run(s, map, o);
      std::printf("[ cube-pile %d %s K=%d ] %s, anticipation %d, solver threads %d: %s (one world %s), %llu "
                  "coloured islands, up to %d threads\n",
                  kBodies, kPrecisionName, k, schedule_name(o.schedule), o.runtime.anticipation, threads,
                  hash_hex(r.hash).c_str(), hash_hex(reference).c_str(),
                  static_cast<unsigned long long>(r.total.coloured_islands), r.total.solver_threads);
      EXPECT_EQ(hash_hex(r.hash), hash_hex(reference)) << "K=" << k << ", solver threads " << threads;
      expect_coloured(r, k, threads, o.runtime.solver_guests);
    }
  }
}

// Waiting world threads as guests of the pool (PartitionedOptions::
// solver_guests, scheduler.h): while the root solves the merged heap, the
// other worlds' threads, blocked on their mailboxes, take tasks of its
// colours. One-world hash; the guests really took tasks, and their CPU time
// is their own world's (stage solve). Whether a guest gets one of a small
// colour's few tasks before the root has run them all is a matter of
// timing (on 2 cores at K = 2 from 0 to thousands in 150 steps; at K >= 4
// thousands), so the count is checked over all the runs.
TEST(ColouredSolve, WaitingWorldsServeTheRootsSolve) {
  const Scene s = test::scene("cube-pile", kBodies);
  const std::uint64_t reference = test::reference_hash(s, kSteps);
  struct Config {
    int k, solver_threads, guests, anticipation;
  };
#if defined(__SANITIZE_THREAD__)
  const std::vector<Config> configs = {{2, 1, 1, 0}, {4, 2, 3, 8}};
#else
  const std::vector<Config> configs = {{2, 1, 1, 0}, {2, 2, 1, 8}, {4, 1, 1, 0}, {4, 2, 3, 8}, {8, 1, 7, 0}};
#endif
  std::uint64_t guest_tasks = 0;
  for (const Config& c : configs) {
    PartitionedOptions o;
    o.schedule = Schedule::ThreadPerWorld;
    o.runtime.anticipation = c.anticipation;
    o.runtime.solver_threads = c.solver_threads;
    o.runtime.solver_guests = c.guests;
    PartitionedWorld w(s, make_partition("kmeans", s, c.k, GridOptions{}), o);
    w.step(kSteps);
    const std::vector<WorldMetrics> metrics = w.metrics();
    const WorldMetrics total = test::total(metrics);
    std::printf("[ cube-pile %d %s K=%d ] solver threads %d, guests %d, anticipation %d: %s (one world %s), %llu "
                "tasks taken by guests\n",
                kBodies, kPrecisionName, c.k, c.solver_threads, c.guests, c.anticipation,
                hash_hex(w.state_hash()).c_str(), hash_hex(reference).c_str(),
                static_cast<unsigned long long>(total.guest_tasks));
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference)) << "K=" << c.k << ", guests " << c.guests;
    expect_coloured(Outcome{w.state_hash(), total}, c.k, c.solver_threads, c.guests);
    guest_tasks += total.guest_tasks;
    for (const WorldMetrics& m : metrics)
      if (m.guest_tasks > 0) {
        EXPECT_GT(m.stages[static_cast<std::size_t>(Stage::Solve)].cpu_seconds, 0.0) << "world " << m.world;
      }
  }
  EXPECT_GT(guest_tasks, 0u) << "no waiting world took a task of a root's solve";
}

// Guests must be a count (or -1, automatic).
TEST(ColouredSolve, SolverGuestsMustNotBeBelowMinusOne) {
  const Scene s = test::scene("cube-pile", 20);
  PartitionedOptions o;
  o.schedule = Schedule::ThreadPerWorld;
  o.runtime.solver_guests = -2;
  EXPECT_THROW(PartitionedWorld(s, make_partition("kmeans", s, 2, GridOptions{}), o), std::invalid_argument);
}

// The other scenes of the fuzz suite, each on its own partition, with 3
// and 8 solver threads and anticipation 8: their islands are small (Bullet's
// loop), the pool must change nothing.
TEST(ColouredSolve, BorderScenesAndFallingCubesWithSolverThreads) {
  for (const test::Case& c : test::mixed_cases()) {
    if (std::string(c.scene) == "cube-pile") continue;
    const Scene s = test::scene(c.scene, c.n);
    const std::uint64_t reference = test::reference_hash(s, kSteps);
    for (int threads : {3, 8}) {
      PartitionedOptions o;
      o.schedule = Schedule::ThreadPerWorld;
      o.runtime.anticipation = 8;
      o.runtime.solver_threads = threads;
      const Outcome r = run(s, test::map_of(c, s), o);
      std::printf("[ %s %s %s K=%d ] solver threads %d: %s (one world %s), %llu coloured islands\n", c.scene,
                  kPrecisionName, c.partition, c.territories, threads, hash_hex(r.hash).c_str(),
                  hash_hex(reference).c_str(), static_cast<unsigned long long>(r.total.coloured_islands));
      EXPECT_EQ(hash_hex(r.hash), hash_hex(reference)) << c.scene << ", solver threads " << threads;
    }
  }
}

TEST(ColouredSolve, SyncTestWithSolverThreads) {
  // Not shorter under TSan: the heap is solved coloured only once it has
  // formed (at 60 steps, 8 coloured islands instead of > kMinColoured).
  const Scene s = test::scene("cube-pile", kBodies);
  PartitionedOptions o;
#if defined(__SANITIZE_THREAD__)  // each step re-run from fewer steps back: a third of the work
  o.sync_test = 2;
#else
  o.sync_test = 8;
#endif
  o.runtime.solver_threads = 3;
  PartitionedWorld w(s, make_partition("rcb", s, 3, GridOptions{}), o);
  w.step(kSteps);
  EXPECT_EQ(w.sync_rollbacks(), static_cast<std::uint64_t>(kSteps));
  EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(test::reference_hash(s, kSteps)));
  expect_coloured(Outcome{w.state_hash(), test::total(w.metrics())}, 3, 3);
}

// Random pauses in every stage and message (the fuzz suite's hooks) while
// the pool's helpers share the colours: still the one-world hash.
TEST(ColouredSolve, FuzzedWithSolverThreads) {
  const Scene s = test::scene("cube-pile", kBodies);
  const std::uint64_t reference = test::reference_hash(s, kSteps);
#if defined(__SANITIZE_THREAD__)
  constexpr int kSeeds = 3;
#else
  constexpr int kSeeds = 6;
#endif
  const int ks[] = {2, 4, 8};
  const int solver_threads[] = {2, 3, 8};
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const int k = ks[seed % 3];
    PartitionedOptions o;
    o.schedule = seed % 2 ? Schedule::ThreadPerWorld : Schedule::Pool;
    o.threads = 2;
    o.runtime.solver_threads = solver_threads[(seed / 3) % 3];
    o.runtime.validate = true;
    detail::edit_testing_hooks(o).fuzz_seed = static_cast<std::uint64_t>(seed);
    const Outcome r = run(s, make_partition("kmeans", s, k, GridOptions{}), o);
    EXPECT_EQ(hash_hex(r.hash), hash_hex(reference))
        << "seed " << seed << ", K=" << k << ", solver threads " << o.runtime.solver_threads;
    EXPECT_GT(r.total.coloured_islands, 0u);
  }
}

// The step's per-body and per-pair stages on the pool (parallel_stages.h):
// scenes above kParallelMinBodies, one territory with 1, 2, 3, 8 solver
// threads and two territories with 1 and 2 give the one-world hash, and the
// stages really ran on the pool's threads. cube-pile: one heap (coloured);
// falling-cubes: small islands.
struct StagesRun {
  std::uint64_t hash = 0;
  int stage_threads = 0;    // most over the run
  int substep_threads = 0;  // most over the run (island_substeps.h)
  int island_threads = 0;   // most over the run: small islands side by side
};

StagesRun run_canonical(const Scene& s, int steps, int solver_threads) {
  CanonicalWorld w(s);
  if (solver_threads > 1) w.set_solver_pool(std::make_shared<SolverPool>(solver_threads));
  StagesRun r;
  for (int i = 0; i < steps; ++i) {
    w.step();
    r.stage_threads = std::max(r.stage_threads, w.last_step_stats().stage_threads);
    r.substep_threads = std::max(r.substep_threads, w.last_step_stats().substep_threads);
    r.island_threads = std::max(r.island_threads, w.last_step_stats().island_threads);
  }
  r.hash = w.state_hash();
  return r;
}

TEST(ColouredSolve, StepStagesOnThePoolEveryThreadCount) {
#if defined(__SANITIZE_THREAD__)  // TSan looks for races: fewer, shorter runs
  constexpr int kStageSteps = 40;
  const std::vector<int> solver_threads = {1, 3};
#else
  constexpr int kStageSteps = 120;
  const std::vector<int> solver_threads = {1, 2, 3, 8};
#endif
  constexpr int kStageBodies = kParallelMinBodies + 88;  // 600: the per-body stages are shared
  for (const char* name : {"cube-pile", "falling-cubes"}) {
    const Scene s = test::scene(name, kStageBodies);
    const std::uint64_t reference = test::reference_hash(s, kStageSteps);
    for (int threads : solver_threads) {
      const StagesRun r = run_canonical(s, kStageSteps, threads);
      std::printf("[ %s %d %s K=1 ] solver threads %d: %s (no pool %s), stages on up to %d threads, "
                  "between substeps %d, small islands %d\n",
                  name, kStageBodies, kPrecisionName, threads, hash_hex(r.hash).c_str(), hash_hex(reference).c_str(),
                  r.stage_threads, r.substep_threads, r.island_threads);
      EXPECT_EQ(hash_hex(r.hash), hash_hex(reference)) << name << ", solver threads " << threads;
      EXPECT_EQ(r.stage_threads, threads) << name << ": the step's stages did not get the pool's threads";
#if !defined(__SANITIZE_THREAD__)
      // falling-cubes lands as hundreds of small islands (a cube on the
      // ground, small clusters): solved side by side on the pool.
      if (std::string(name) == "falling-cubes") {
        EXPECT_EQ(r.island_threads, threads) << name << ": the small islands did not get the pool's threads";
      }
#endif
      // cube-pile's heap lands interpenetrating: substepped, and its
      // manifolds' refresh between substeps is shared on the pool. Under
      // TSan's 40 steps only smaller islands are substepped (below the
      // pool's sizes, parallel_stages.h): substeps ran, on one thread.
      if (std::string(name) == "cube-pile") {
#if defined(__SANITIZE_THREAD__)
        EXPECT_EQ(r.substep_threads, 1) << name << ": no island was substepped";
#else
        EXPECT_EQ(r.substep_threads, threads) << name << ": the work between substeps did not get the pool's threads";
#endif
      }
    }
    for (int threads : {1, 2}) {
      PartitionedOptions o;
      o.schedule = Schedule::ThreadPerWorld;
      o.runtime.solver_threads = threads;
      o.runtime.solver_guests = threads - 1;
      PartitionedWorld w(s, make_partition("kmeans", s, 2, GridOptions{}), o);
      w.step(kStageSteps);
      EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference)) << name << ", K=2, solver threads " << threads;
    }
  }
}

// heap (docs/scenes.md): one territory equals K = 2 and 4.
TEST(ColouredSolve, HeapOneTerritoryEqualsK) {
  constexpr int kHeapBodies = 150;
  constexpr int kHeapSteps = 150;
  const Scene s = test::scene("heap", kHeapBodies);
  const std::uint64_t reference = test::reference_hash(s, kHeapSteps);
#if defined(__SANITIZE_THREAD__)  // TSan looks for races: one partitioned run
  const std::vector<int> ks = {4};
#else
  const std::vector<int> ks = {2, 4};
#endif
  for (int k : ks) {
    PartitionedOptions o;
    o.runtime.solver_threads = 2;
    PartitionedWorld w(s, make_partition("kmeans", s, k, GridOptions{}), o);
    w.step(kHeapSteps);
    std::printf("[ heap %d %s K=%d ] %s (one world %s)\n", kHeapBodies, kPrecisionName, k,
                hash_hex(w.state_hash()).c_str(), hash_hex(reference).c_str());
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference)) << "heap, K=" << k;
  }
}

TEST(ColouredSolve, SolverThreadsMustBePositive) {
  const Scene s = test::scene("cube-pile", 20);
  PartitionedOptions o;
  o.runtime.solver_threads = 0;
  EXPECT_THROW(PartitionedWorld(s, make_partition("kmeans", s, 2, GridOptions{}), o), std::invalid_argument);
}

}  // namespace
}  // namespace soda
