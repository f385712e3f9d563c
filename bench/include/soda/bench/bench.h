// bench/ — benchmarks that print machine-readable results, every speed
// figure a ratio against a baseline measured side by side in the same run:
// one plain Bullet world (StockWorld) on the same scene.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "soda/runtime/run.h"

namespace soda {

struct BenchConfig {
  RunConfig run;   // the configuration under test (run.sleeping is ignored: see awake_pair)
  int repeat = 3;  // interleaved repeats of (baseline, run); the minimum of each is kept
  /// Also run every configuration again with sleeping off in every world
  /// (RunConfig::sleeping = false): BenchResult::awake, the comparison in
  /// which no side gains from putting bodies to sleep sooner.
  bool awake_pair = true;
};

/// One side-by-side comparison with one sleeping setting: the configuration
/// under test, the stock baseline and (territories > 1) the one-territory
/// run, each the fastest of its interleaved repeats.
struct BenchSet {
  RunResult run;
  RunResult baseline;
  RunResult one_territory;               // territories > 1 only
  std::vector<double> run_walls;         // every repeat, seconds
  std::vector<double> baseline_walls;
  std::vector<double> one_territory_walls;
  double ratio_vs_baseline = 0;          // baseline.wall_seconds / run.wall_seconds (> 1: faster than stock)
  double speedup_vs_one_territory = 0;   // one_territory.wall_seconds / run.wall_seconds (territories > 1)
};

/// What bench_scene measured. The BenchSet fields are the runs with
/// sleeping on (Bullet's default, what users run).
struct BenchResult : BenchSet {
  /// With BenchConfig::awake_pair: the same runs with sleeping off in every
  /// world (ratio_vs_baseline_awake = awake.ratio_vs_baseline).
  bool has_awake = false;
  BenchSet awake;
};

/// The verdict `soda bench` exits with: 0 when every K-territory run's
/// state hash equals its one-territory run's (sleeping on and, if run, off),
/// or when there is one territory only; 1 otherwise (a decomposition error:
/// a bug, never a tolerance).
int bench_exit_code(const BenchResult& b);

/// The short human-readable table `soda bench` prints: wall time and ratios
/// of every configuration, sleeping on and off, the bodies asleep at the end
/// and the hash check. One line per row, ending in a newline.
std::string bench_table(const BenchResult& b);

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
/// rotation. With config.awake_pair the whole rotation is repeated with
/// sleeping off (BenchResult::awake). Throws what run_scene throws;
/// repeat < 1 is std::invalid_argument.
BenchResult bench_scene(const Scene& scene, const BenchConfig& config);

}  // namespace soda
