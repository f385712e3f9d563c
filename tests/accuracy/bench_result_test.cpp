// `soda bench`'s verdict and table (bench.h): a decomposition error (a
// K-territory hash that differs from the one-territory hash, sleeping on or
// off) makes the exit code 1 and the table say so; a small real bench runs
// both sleeping settings side by side.
#include <string>

#include <gtest/gtest.h>

#include "soda/bench/bench.h"
#include "soda/scene/registry.h"

namespace soda {
namespace {

// A two-territory result whose every hash agrees, both sleeping settings.
BenchResult agreeing() {
  BenchResult b;
  for (BenchSet* s : {static_cast<BenchSet*>(&b), &b.awake}) {
    s->run.territories = 2;
    s->run.state_hash = 0x1234;
    s->one_territory.state_hash = 0x1234;
    s->baseline.state_hash = 0x9999;  // stock Bullet: never compared
  }
  b.has_awake = true;
  return b;
}

TEST(BenchExitCode, ZeroWhenEveryHashAgrees) {
  EXPECT_EQ(bench_exit_code(agreeing()), 0);
  const std::string t = bench_table(agreeing());
  EXPECT_NE(t.find("identical"), std::string::npos) << t;
  EXPECT_EQ(t.find("DIFFERENT"), std::string::npos) << t;
}

TEST(BenchExitCode, OneWhenTheSleepingRunsDiffer) {
  BenchResult b = agreeing();
  b.run.state_hash = 0x1235;
  EXPECT_EQ(bench_exit_code(b), 1);
  EXPECT_NE(bench_table(b).find("DIFFERENT"), std::string::npos) << bench_table(b);
}

TEST(BenchExitCode, OneWhenTheAwakeRunsDiffer) {
  BenchResult b = agreeing();
  b.awake.one_territory.state_hash = 0x1;
  EXPECT_EQ(bench_exit_code(b), 1);
  b.has_awake = false;  // not run: not judged
  EXPECT_EQ(bench_exit_code(b), 0);
}

TEST(BenchExitCode, OneTerritoryHasNothingToCompare) {
  BenchResult b = agreeing();
  b.run.territories = 1;
  b.awake.run.territories = 1;
  b.run.state_hash = 0x5;
  EXPECT_EQ(bench_exit_code(b), 0);
}

TEST(BenchScene, RunsBothSleepingSettingsSideBySide) {
  const Scene s = make_scene("falling-cubes", {100, 1});
  BenchConfig c;
  c.run.steps = 330;
  c.run.territories = 2;
  c.run.threads = 1;
  c.run.shuffle_seed = 3;
  c.run.progress_seconds = 0;
  c.repeat = 1;
  const BenchResult b = bench_scene(s, c);
  ASSERT_TRUE(b.has_awake);
  EXPECT_EQ(bench_exit_code(b), 0);
  EXPECT_EQ(b.run.state_hash, b.one_territory.state_hash);
  EXPECT_EQ(b.awake.run.state_hash, b.awake.one_territory.state_hash);
  EXPECT_NE(b.run.state_hash, b.awake.run.state_hash);
  EXPECT_GT(b.run.sleeping_bodies, 0u);
  EXPECT_GT(b.baseline.sleeping_bodies, 0u);
  for (const RunResult* r : {&b.awake.run, &b.awake.one_territory, &b.awake.baseline})
    EXPECT_EQ(r->sleeping_bodies, 0u);
  EXPECT_EQ(b.run_walls.size(), 1u);
  EXPECT_EQ(b.awake.baseline_walls.size(), 1u);
  // baseline time / our time, > 1: faster than stock (the table's speed-up column).
  EXPECT_NEAR(b.awake.ratio_vs_baseline, b.awake.baseline.wall_seconds / b.awake.run.wall_seconds, 1e-12);
  EXPECT_NEAR(b.ratio_vs_baseline, b.baseline.wall_seconds / b.run.wall_seconds, 1e-12);
  const std::string t = bench_table(b);
  std::printf("%s", t.c_str());
  EXPECT_NE(t.find("sleeping off"), std::string::npos) << t;
}

}  // namespace
}  // namespace soda
