// The coloured solve of large islands across territories
// (docs/coloured-solve.md): a heap solved as a local island (one territory)
// or as a merged border island (several) gives the one-world hash for every
// number of solver threads, schedule and anticipation, and the coloured
// path really ran, on the pool's threads (label "concurrency").
#include <gtest/gtest.h>

#include "runtime/partitioned_test_util.h"

namespace soda {
namespace {

constexpr int kBodies = 300;
constexpr int kSteps = 120;

struct Outcome {
  std::uint64_t hash;
  WorldMetrics total;
};

Outcome run(const Scene& s, int k, PartitionedOptions o) {
  PartitionedWorld w(s, make_partition("kmeans", s, k, GridOptions{}), o);
  w.step(kSteps);
  return Outcome{w.state_hash(), test::total(w.metrics())};
}

TEST(ColouredSolve, CubePileAnyTerritoriesAnySolverThreads) {
  const Scene s = test::scene("cube-pile", kBodies);
  const std::uint64_t reference = test::reference_hash(s, kSteps);
  struct Config {
    int k, solver_threads;
    Schedule schedule;
    int anticipation;
  };
  for (const Config c : {Config{1, 1, Schedule::Sequential, 0}, Config{1, 3, Schedule::Sequential, 0},
                         Config{2, 1, Schedule::ThreadPerWorld, 0}, Config{2, 2, Schedule::ThreadPerWorld, 0},
                         Config{3, 8, Schedule::ThreadPerWorld, 8}, Config{4, 3, Schedule::Sequential, 0}}) {
    PartitionedOptions o;
    o.schedule = c.schedule;
    o.solver_threads = c.solver_threads;
    o.anticipation = c.anticipation;
    const Outcome r = run(s, c.k, o);
    std::printf("[ cube-pile %d %s K=%d ] solver threads %d, anticipation %d: %s (one world %s), %llu coloured "
                "islands, up to %d threads\n",
                kBodies, kPrecisionName, c.k, c.solver_threads, c.anticipation, hash_hex(r.hash).c_str(),
                hash_hex(reference).c_str(), static_cast<unsigned long long>(r.total.coloured_islands),
                r.total.solver_threads);
    EXPECT_EQ(hash_hex(r.hash), hash_hex(reference)) << "K=" << c.k << ", solver threads " << c.solver_threads;
    EXPECT_GT(r.total.coloured_islands, static_cast<std::uint64_t>(kSteps / 2));
    EXPECT_EQ(r.total.solver_threads, c.solver_threads);
    if (c.k > 1) {
      EXPECT_GT(r.total.islands_solved, 0u);
    }
  }
}

TEST(ColouredSolve, SolverThreadsMustBePositive) {
  const Scene s = test::scene("cube-pile", 20);
  PartitionedOptions o;
  o.solver_threads = 0;
  EXPECT_THROW(PartitionedWorld(s, make_partition("kmeans", s, 2, GridOptions{}), o), std::invalid_argument);
}

}  // namespace
}  // namespace soda
