// bench/ — benchmarks that print machine-readable results, every speed
// figure a ratio against a baseline measured side by side in the same run:
// one plain Bullet world (StockWorld) on the same scene.
#pragma once

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
  std::vector<double> run_walls;         // every repeat, seconds
  std::vector<double> baseline_walls;
  double ratio_vs_baseline = 0;          // run.wall_seconds / baseline.wall_seconds (< 1: faster)
};

/// Runs the baseline and `config.run` on `scene`, interleaved: repeat i runs
/// the baseline first when i is even, the run under test first when odd, so
/// that neither side always gets the warm (or cold) machine. Throws what
/// run_scene throws; repeat < 1 is std::invalid_argument.
BenchResult bench_scene(const Scene& scene, const BenchConfig& config);

}  // namespace soda
