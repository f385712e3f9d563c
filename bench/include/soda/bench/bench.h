// bench/ — benchmarks that print machine-readable results, every speed
// figure a ratio against a baseline measured side by side in the same run:
// one plain Bullet world (StockWorld) on the same scene.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "soda/runtime/run.h"

namespace soda {

struct BenchConfig {
  RunConfig run;   // the configuration under test
  int repeat = 3;  // interleaved repeats of (baseline, run); the minimum of each is kept
};

struct BenchResult {
  RunResult run;                         // the fastest repeat of the run under test
  RunResult baseline;                    // the fastest repeat of the baseline
  /// territories > 1 only: the fastest repeat of the same world kind on one
  /// territory (our own sequential run), the reference of the speed-up and
  /// of the decomposition check.
  RunResult one_territory;
  std::vector<double> one_territory_walls;
  std::vector<double> run_walls;         // every repeat, seconds
  std::vector<double> baseline_walls;
  double ratio_vs_baseline = 0;          // run.wall_seconds / baseline.wall_seconds (< 1: faster)
  double speedup_vs_one_territory = 0;   // one_territory.wall_seconds / run.wall_seconds (territories > 1)
};

/// The thesis' scalability measure from per-world CPU times: for each step
/// the CPU time of the slowest world, summed over steps. Divided into a
/// sequential run's CPU time it gives the speed-up the run would reach with
/// one core per world (a projection on a machine with fewer cores).
double slowest_world_cpu_seconds(const std::vector<WorldMetrics>& worlds);

/// bodies_resolved / rollbacks of one world or of total_metrics over all
/// (0 without rollbacks): bodies re-solved per rollback, lower is better.
double bodies_resolved_per_rollback(const WorldMetrics& m);

/// bodies_resolved / bets_lost (0 without lost bets): bodies re-solved per
/// lost bet, the measure that compares Rollback and Propagate with discard
/// and recompute (one lost bet is one rollback of every world there, a few
/// local rollbacks here).
double bodies_resolved_per_lost_bet(const WorldMetrics& m);

/// Runs the baseline and `config.run` on `scene`, interleaved: repeat i runs
/// the baseline first when i is even, the run under test first when odd, so
/// that neither side always gets the warm (or cold) machine. With
/// territories > 1 a one-territory run of the same world kind joins the
/// rotation. Throws what run_scene throws; repeat < 1 is
/// std::invalid_argument.
BenchResult bench_scene(const Scene& scene, const BenchConfig& config);

}  // namespace soda
