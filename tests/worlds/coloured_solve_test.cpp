// The coloured solve of large islands (docs/coloured-solve.md): it runs on
// a heap, its result does not depend on the number of solver threads, on
// the insertion order nor on the other islands of the world, it equals
// Bullet's own loop run in the colour order for any solver settings, and a
// pool really gives its threads to the solve.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "coloured_solver.h"
#include "island_solver_settings.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/solver_pool.h"
#include "soda/worlds/stock_world.h"
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

// The island under test (a pile at the origin, ids as generated) beside a
// bigger pile far away with ids above it: the pile's bodies must end in the
// same bits as in a world of their own. Regression: the choice coloured or
// stock once read entries of Bullet's contact order array that setup leaves
// uninitialised under SOLVER_USE_2_FRICTION_DIRECTIONS (what earlier,
// larger islands wrote), so it depended on the world's other islands.
TEST(ColouredSolve, AnIslandIgnoresTheOtherIslandsOfItsWorld) {
  constexpr int kSteps = 150;
  const Scene alone = test::scene("cube-pile", 150);
  Scene both = alone;
  constexpr BodyId kFarIds = 100000;
  for (Body b : test::scene("cube-pile", 500).bodies) {
    b.id += kFarIds;
    b.position.x() += 200.0;
    both.bodies.push_back(b);
  }
  CanonicalWorld a(alone), b(both);
  std::size_t coloured = 0;
  for (int s = 0; s < kSteps; ++s) {
    a.step();
    b.step();
    coloured += a.last_step_stats().coloured_islands;
  }
  std::vector<BodyState> pile = b.body_states();
  std::erase_if(pile, [&](const BodyState& s) { return s.id >= kFarIds; });
  std::printf("[ cube-pile 150 %s ] alone %s, beside cube-pile 500: %s, %zu coloured steps\n", kPrecisionName,
              hash_hex(a.state_hash()).c_str(), hash_hex(state_hash(pile)).c_str(), coloured);
  EXPECT_GT(coloured, std::size_t{0}) << "the pile was never solved coloured: the test tests nothing";
  EXPECT_EQ(hash_hex(state_hash(pile)), hash_hex(a.state_hash()));
}

// The coloured loop against its definition: Bullet's own sequential loop
// with its order arrays set to the colour order (Mode::SequentialInColourOrder),
// under the canonical solver settings (two fixed friction directions),
// for several iteration counts and with and without an early exit, on
// 1 and 3 solver threads. A stock world drives both solvers (same islands,
// same solveGroup calls); only the solver differs.
struct OracleRun {
  std::uint64_t hash = 0;
  std::size_t coloured_islands = 0;
  std::size_t wide_islands = 0;
  std::size_t avx2_islands = 0;
};

OracleRun run_stock_world(int iterations, double residual_threshold, ColouredSolver::Mode mode, int threads) {
  Scene scene = test::scene("cube-pile", 200);
  scene.settings.iterations = iterations;
  ColouredSolver solver;  // outlives the world that points to it
  solver.set_mode(mode);
  if (threads > 1) solver.set_pool(std::make_shared<SolverPool>(threads));
  StockWorld world(scene);
  world.bullet().setConstraintSolver(&solver);
  configure_canonical_solver(world.bullet().getSolverInfo(), scene.settings);
  world.bullet().getSolverInfo().m_leastSquaresResidualThreshold = btScalar(residual_threshold);
  test::run(world, 120);
  return OracleRun{world.state_hash(), solver.stats().coloured_islands, solver.stats().wide_islands,
                   solver.stats().avx2_islands};
}

// Lets the wide rows take the AVX2 kernel (where the CPU has it) or not,
// for the guard's lifetime.
struct AllowAvx2 {
  explicit AllowAvx2(bool allow) { WideRows::allow_avx2(allow); }
  ~AllowAvx2() { WideRows::allow_avx2(true); }
};

TEST(ColouredSolve, EqualsBulletsLoopInTheColourOrder) {
#if defined(__SANITIZE_THREAD__)  // TSan looks for races: one iteration count, the early exit on
  const int iteration_counts[] = {10};
  const double thresholds[] = {1e-4};
#else
  const int iteration_counts[] = {4, 10, 30};
  const double thresholds[] = {0.0, 1e-4};
#endif
  for (int iterations : iteration_counts) {
    for (double threshold : thresholds) {
      const OracleRun reference =
          run_stock_world(iterations, threshold, ColouredSolver::Mode::SequentialInColourOrder, 1);
      ASSERT_GT(reference.coloured_islands, std::size_t{0}) << "nothing was coloured: the test tests nothing";
      // Both kernels of the wide rows: AVX2 where this CPU has it, and SSE2.
      for (const bool avx2 : {true, false})
        for (int threads : {1, 3}) {
          const AllowAvx2 allow(avx2);
          const OracleRun coloured = run_stock_world(iterations, threshold, ColouredSolver::Mode::Coloured, threads);
          std::printf("[ cube-pile 200 %s ] %d iterations, threshold %g, %d thread(s), %zu of %zu islands on AVX2: "
                      "colour order %s, coloured %s\n",
                      kPrecisionName, iterations, threshold, threads, coloured.avx2_islands, coloured.wide_islands,
                      hash_hex(reference.hash).c_str(), hash_hex(coloured.hash).c_str());
          EXPECT_EQ(hash_hex(coloured.hash), hash_hex(reference.hash))
              << iterations << " iterations, threshold " << threshold << ", " << threads << " thread(s), AVX2 "
              << avx2;
          EXPECT_EQ(coloured.coloured_islands, reference.coloured_islands);
          // The float build solves the colours' contact and friction rows
          // eight runs at a time (wide_rows.h), the double build in the
          // scalar loop: either way the bits of Bullet's loop.
#ifdef BT_USE_DOUBLE_PRECISION
          EXPECT_EQ(coloured.wide_islands, std::size_t{0});
#else
          EXPECT_EQ(coloured.wide_islands, coloured.coloured_islands) << "the wide rows did not run";
          EXPECT_EQ(coloured.avx2_islands, avx2 && wide::avx2_supported() ? coloured.wide_islands : 0)
              << "the kernel asked for did not run";
#endif
        }
    }
  }
}

// The contact and friction rows of a point set up together (point_rows.h),
// and the solver bodies and rows built on the pool and the write-back on the
// pool (coloured_setup.cpp) equal Bullet's serial convertBodies,
// convertContacts (its setupContactConstraint and setupFrictionConstraint
// calls) and solveGroupCacheFriendlyFinish: the same solver, with and without
// a pool, under the solver modes whose friction rows differ (one or two
// directions, velocity-dependent or fixed directions, direction caching)
// and with and without warm starting (the only part that adds into the
// solver bodies). The sweeps give the same bits on any thread count
// (EqualsBulletsLoopInTheColourOrder), so a difference is the row setup's.
struct SetupRun {
  std::uint64_t hash = 0;
  std::size_t coloured_islands = 0;
  std::size_t point_rows = 0;
  int setup_threads = 0;
  int body_setup_threads = 0;
  int finish_threads = 0;
};

// Lets a point's rows be set up together (point_rows.h) or by Bullet's
// calls, for the guard's lifetime.
struct AllowPointRows {
  explicit AllowPointRows(bool allow) { ColouredSolver::allow_point_rows(allow); }
  ~AllowPointRows() { ColouredSolver::allow_point_rows(true); }
};

SetupRun run_setup_world(int solver_mode, int threads) {
  // One island above kParallelMinSolverBodies; coloured from step ~56 on.
  Scene scene = test::scene("cube-pile", 300);
  ColouredSolver solver;  // outlives the world that points to it
  if (threads > 1) solver.set_pool(std::make_shared<SolverPool>(threads));
  StockWorld world(scene);
  world.bullet().setConstraintSolver(&solver);
  configure_canonical_solver(world.bullet().getSolverInfo(), scene.settings);
  world.bullet().getSolverInfo().m_solverMode = solver_mode;
  test::run(world, 60);
  return SetupRun{world.state_hash(), solver.stats().coloured_islands, solver.stats().point_rows,
                  solver.stats().setup_threads_max,
                  solver.stats().body_setup_threads_max, solver.stats().finish_threads_max};
}

TEST(ColouredSolve, RowSetupOnThePoolEqualsBulletsLoop) {
  const int modes[] = {
#if !defined(__SANITIZE_THREAD__)  // TSan looks for races: the canonical mode suffices
      SOLVER_SIMD | SOLVER_USE_WARMSTARTING | SOLVER_USE_2_FRICTION_DIRECTIONS,
      SOLVER_SIMD | SOLVER_USE_WARMSTARTING,
      SOLVER_SIMD | SOLVER_USE_2_FRICTION_DIRECTIONS,
#endif
      SOLVER_SIMD | SOLVER_USE_WARMSTARTING | SOLVER_USE_2_FRICTION_DIRECTIONS |
          SOLVER_DISABLE_VELOCITY_DEPENDENT_FRICTION_DIRECTION | SOLVER_ENABLE_FRICTION_DIRECTION_CACHING,
  };
  for (int mode : modes) {
    SetupRun bullet_rows;  // each row by Bullet's own setup call
    {
      const AllowPointRows allow(false);
      bullet_rows = run_setup_world(mode, 1);
    }
    const SetupRun serial = run_setup_world(mode, 1);
    ASSERT_GT(serial.coloured_islands, std::size_t{0}) << "nothing was coloured: the test tests nothing";
    EXPECT_EQ(bullet_rows.point_rows, std::size_t{0}) << "the reference did not take Bullet's calls";
    EXPECT_GT(serial.point_rows, std::size_t{0}) << "no point's rows were set up together: the test tests nothing";
    EXPECT_EQ(serial.setup_threads, 0) << "no pool";
    EXPECT_EQ(serial.body_setup_threads, 0) << "no pool: Bullet's loop";
    EXPECT_EQ(serial.finish_threads, 0) << "no pool: Bullet's loop";
    const SetupRun pooled = run_setup_world(mode, 3);
    std::printf("[ cube-pile 300 %s ] solver mode 0x%x: Bullet's row setup %s, serial rows %s, rows on %d threads %s\n",
                kPrecisionName, mode, hash_hex(bullet_rows.hash).c_str(), hash_hex(serial.hash).c_str(),
                pooled.setup_threads, hash_hex(pooled.hash).c_str());
    EXPECT_EQ(hash_hex(serial.hash), hash_hex(bullet_rows.hash))
        << "a point's rows set up together differ from Bullet's calls, solver mode 0x" << std::hex << mode;
    EXPECT_EQ(pooled.setup_threads, 3) << "the rows were not built on the pool: the test tests nothing";
    EXPECT_EQ(pooled.body_setup_threads, 3) << "the solver bodies were not set up on the pool";
    EXPECT_EQ(pooled.finish_threads, 3) << "the write-back did not run on the pool";
    EXPECT_EQ(hash_hex(pooled.hash), hash_hex(serial.hash)) << "solver mode 0x" << std::hex << mode;
  }
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

// The tests below make two tasks wait for each other: a correct pool meets
// them within microseconds, a wrong one leaves them waiting for ever. The
// wait is a hang guard only, far above any normal run (ThreadSanitizer on a
// loaded 2-core machine included): it turns a hang into a failure, and no
// timing decides a pass.
constexpr std::chrono::minutes kHangGuard{2};

// Home blocks: of a job of 4 tasks on 2 threads, the caller takes tasks 0
// and 1 (block 0), the helper 2 and 3 (block 1). Task 0 and task 2 wait for
// each other, then 1 and 3: with one shared counter the helper would take
// task 1 and both threads would wait for ever (kHangGuard turns that into a
// failure).
TEST(SolverPool, EachThreadStartsInItsOwnBlock) {
  SolverPool pool(2);
  for (int round = 0; round < 20; ++round) {
    std::atomic<int> started[4] = {0, 0, 0, 0};
    std::thread::id ran_by[4];
    std::atomic<bool> met{true};
    const auto deadline = std::chrono::steady_clock::now() + kHangGuard;
    const std::thread::id caller = std::this_thread::get_id();
    pool.run(4, [&](int i) {
      ran_by[i] = std::this_thread::get_id();
      started[i] = 1;
      const int partner = (i + 2) % 4;
      while (!started[partner].load() && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
      if (!started[partner].load()) met = false;
    });
    ASSERT_TRUE(met.load()) << "round " << round << ": a task's partner never started";
    EXPECT_EQ(ran_by[0], caller);
    EXPECT_EQ(ran_by[1], caller);
    EXPECT_NE(ran_by[2], caller);
    EXPECT_EQ(ran_by[3], ran_by[2]);
  }
}

// Guests (SolverPool::serve): threads that are not the pool's take tasks of
// its jobs while they serve, every task still runs once, a guest leaves when
// told, and a guest beyond the slots is turned away at once.
TEST(SolverPool, GuestsTakeTasksUntilTold) {
  SolverPool pool(1, 2);  // no helper: the guests are the only other threads
  EXPECT_EQ(pool.threads(), 3);
  std::atomic<bool> until[2] = {false, false};
  SolverPool::Served served[2];
  std::vector<std::thread> guests;
  for (int g = 0; g < 2; ++g) guests.emplace_back([&, g] { served[g] = pool.serve(until[g]); });
  while (pool.guests() < 2) std::this_thread::yield();
  // A job of two tasks that each wait for the other: done only if a guest
  // takes one (the caller alone would wait for ever; kHangGuard turns that
  // into a failure).
  std::atomic<int> running{0};
  std::atomic<bool> met{true};
  const auto deadline = std::chrono::steady_clock::now() + kHangGuard;
  const int threads = pool.run(2, [&](int) {
    running.fetch_add(1);
    while (running.load() < 2 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
    if (running.load() < 2) met = false;
  });
  EXPECT_TRUE(met.load()) << "no guest took the second task";
  EXPECT_EQ(threads, 3);
  for (int round = 0; round < 200; ++round) {
    const int count = 2 + round % 37;
    std::vector<std::atomic<int>> hits(static_cast<std::size_t>(count));
    pool.run(count, [&](int i) { hits[static_cast<std::size_t>(i)].fetch_add(1); });
    for (const auto& h : hits) ASSERT_EQ(h.load(), 1);
  }
  // Guest 0 is told to leave; guest 1 still serves.
  until[0] = true;
  pool.wake_guests();
  guests[0].join();
  EXPECT_EQ(pool.guests(), 1);
  std::atomic<int> done{0};
  pool.run(8, [&](int) { ++done; });
  EXPECT_EQ(done.load(), 8);
  until[1] = true;
  pool.wake_guests();
  guests[1].join();
  EXPECT_EQ(pool.guests(), 0);
  EXPECT_TRUE(served[0].admitted && served[1].admitted);
  EXPECT_GE(served[0].tasks + served[1].tasks, 1) << "the guests counted none of their tasks";
  EXPECT_GT(served[0].busy_ns + served[1].busy_ns, 0) << "the guests' time inside jobs was not measured";
  EXPECT_THROW(SolverPool(1, -1), std::invalid_argument);
}

// A guest that finds every slot taken waits for one, and gets it when the
// holder leaves; told to stop first, it returns without one.
TEST(SolverPool, AGuestWaitsForAFreeSlot) {
  SolverPool pool(1, 1);
  std::atomic<bool> until_first{false}, until_second{false};
  std::thread first([&] { EXPECT_TRUE(pool.serve(until_first).admitted); });
  while (pool.guests() < 1) std::this_thread::yield();
  const std::atomic<bool> at_once{true};
  EXPECT_FALSE(pool.serve(at_once).admitted) << "a guest told to stop took the slot";
  SolverPool::Served second_served;
  std::thread second([&] { second_served = pool.serve(until_second); });
  until_first = true;
  pool.wake_guests();
  first.join();
  while (pool.guests() < 1) std::this_thread::yield();  // the second took the freed slot
  // Only the second guest can take the second task of this job.
  std::atomic<int> running{0};
  std::atomic<bool> met{true};
  const auto deadline = std::chrono::steady_clock::now() + kHangGuard;
  pool.run(2, [&](int) {
    running.fetch_add(1);
    while (running.load() < 2 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
    if (running.load() < 2) met = false;
  });
  EXPECT_TRUE(met.load()) << "the waiting guest did not get the freed slot";
  until_second = true;
  pool.wake_guests();
  second.join();
  EXPECT_TRUE(second_served.admitted);
  EXPECT_GE(second_served.tasks, 1);
  EXPECT_FALSE(SolverPool(1, 0).serve(until_second).admitted);
}

}  // namespace
}  // namespace soda
