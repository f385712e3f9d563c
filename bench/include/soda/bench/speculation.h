// bench/ — `soda bench speculation`: what speculation (PartitionedOptions::
// anticipation) buys over lockstep on a scene whose load alternates between
// territories, and what its rollbacks cost (docs/speculation-bench.md).
//
// Five configurations on one scene, interleaved, the minimum wall time of
// each kept: one stock Bullet world (the baseline of every ratio), our
// canonical world on one territory, K territories in lockstep
// (anticipation 0), K territories with anticipation A and Rollback and
// Propagate, the same with discard-and-recompute. Every state hash but the
// stock world's must equal the one-territory hash.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "soda/bench/bench.h"
#include "soda/bench/result_json.h"

namespace soda {

struct SpeculationBenchConfig {
  /// Steps, partition, threads, territories (K), watchdog... of the
  /// partitioned runs; world, anticipation and rollback are set per run.
  RunConfig run;
  /// Scene steps a world may run past the commit horizon in the speculative
  /// runs. alternating-load's windows last 150 steps: one half's window
  /// overlaps the other's fully once A is about half of that or more.
  int anticipation = 300;  // two load windows of alternating-load: the light world runs a whole window ahead
  int repeat = 3;  // interleaved repeats; the fastest of each configuration is kept
};

/// One configuration and its repeats.
struct SpeculationRun {
  std::string name;              // stock | one-territory | lockstep | propagate | recompute
  RunConfig config;
  RunResult best;                // the fastest repeat
  std::vector<double> walls;     // every repeat, seconds
  std::vector<std::uint64_t> hashes;  // every repeat's state hash
  WorldMetrics totals_all;       // speculation counters summed over worlds and every repeat
};

struct SpeculationBenchResult {
  std::vector<SpeculationRun> runs;  // in the order of `names` below
  static constexpr const char* names[] = {"stock", "one-territory", "lockstep", "propagate", "recompute"};
  const SpeculationRun& run(const std::string& name) const;
  /// Every repeat of every run but the stock world's has the one-territory hash.
  bool hashes_equal = false;
};

/// Runs the five configurations `config.repeat` times, in order on even
/// repeats and in reverse order on odd ones. Throws what run_scene throws;
/// repeat < 1, territories < 2 or anticipation < 1 are std::invalid_argument.
SpeculationBenchResult bench_speculation(const Scene& scene, const SpeculationBenchConfig& config);

/// The bound B of any speculation over lockstep, from a lockstep run's
/// per-world CPU time per internal step: sum over steps of the slowest
/// world's time, divided by the largest world's total. 1: no world ever
/// idles in lockstep; K: the load alternates perfectly. 0 without steps.
double alternation_bound(const std::vector<WorldMetrics>& worlds);

/// A model of speculation limited to `lead` internal steps: the lockstep
/// run's per-step CPU times replayed with no waiting for messages, a world
/// beginning internal step s only once every other world has finished step
/// s - lead (the lead over the commit horizon stays <= lead). Returns the
/// modelled time divided into the lockstep time (sum over steps of the
/// slowest world): the speed-up a speculation that costs nothing would
/// reach. lead <= 1 models lockstep (1.0); large leads reach
/// alternation_bound.
double bounded_lead_speedup(const std::vector<WorldMetrics>& worlds, std::int64_t lead);

/// The benchmark's JSON document (docs/speculation-bench.md).
nlohmann::json speculation_bench_json(const RunDescription& d, const SpeculationBenchConfig& config,
                                      const SpeculationBenchResult& r);

}  // namespace soda
