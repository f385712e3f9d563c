// bench/ — `soda lb`: a load-balance experiment (docs/loadbalance.md,
// "Running an experiment"). One scene run under each balance policy with the
// same seed and the same first map, side by side with one stock Bullet world
// (the baseline of every speed ratio); what every world measured at every
// step, what every balance step moved and cost, the territory maps at chosen
// steps, and a summary per policy. Every policy must end on the state hash
// of the same scene on one territory (load balancing decides speed, never
// physics); the experiment runs that one territory too and checks each.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "soda/bench/result_json.h"
#include "soda/grid/territory_map.h"
#include "soda/runtime/run.h"

namespace soda {

struct LbExperimentConfig {
  /// Territories, partition, threads, steps, anticipation and the balance
  /// knobs shared by every policy; balance.policy is set per run.
  RunConfig run;
  /// Policies run, in this order (make_balance_policy names).
  std::vector<std::string> policies = {"none", "diffusive", "rcb"};
  /// Scene steps whose territory maps maps_csv writes (0: the first map).
  /// Empty: 0, a quarter, half, three quarters and the last step.
  std::vector<std::int64_t> map_steps;
  /// Also run one stock Bullet world (the baseline of ratio_vs_baseline).
  bool baseline = true;
  /// Interleaved repeats (in order on even repeats, reversed on odd ones);
  /// the fastest of each policy is kept. >= 1.
  int repeat = 1;
};

/// One policy and its repeats.
struct LbPolicyRun {
  std::string policy;
  RunResult best;                     // the fastest repeat (its step loads and balance log)
  std::vector<double> walls;          // every repeat, seconds
  std::vector<std::uint64_t> hashes;  // every repeat's state hash
  bool equals_one_territory = false;  // every repeat ends on LbExperimentResult::one_territory_hash
};

/// Imbalance of one run: per scene step, max / mean busy CPU over the worlds.
struct Imbalance {
  double mean = 0;      // mean of the per-step ratios (steps where some world was busy)
  double weighted = 0;  // sum over steps of the max / sum of the mean: heavy steps weigh more
  double max = 0;       // largest per-step ratio
  std::int64_t steps = 0;  // steps counted
};

/// Imbalance of a run's step loads (RunResult::step_loads). 0s without steps.
Imbalance imbalance_of(const std::vector<StepLoads>& loads);

struct LbExperimentResult {
  TerritoryMap first_map;            // every policy's map at step 0 (make_partition's)
  std::optional<RunResult> stock;    // the baseline (config.baseline)
  std::vector<double> stock_walls;
  std::vector<LbPolicyRun> runs;     // in config.policies order
  bool hashes_equal = false;         // every repeat of every policy has one hash
  /// The same scene, steps and inputs on one territory: the hash every
  /// policy must end on (the exactness contract).
  std::uint64_t one_territory_hash = 0;
  bool equals_one_territory = false;  // every repeat of every policy ends on it
};

/// Runs the experiment. Throws what run_scene throws (BalanceError for an
/// unknown policy, before anything runs), std::invalid_argument for no
/// policy, a repeated policy, territories < 2 or repeat < 1. Logs a line
/// per run through spdlog (run_scene's own progress lines in between).
LbExperimentResult run_lb_experiment(const Scene& scene, const LbExperimentConfig& config);

/// The map in force at scene step `step` of a run: the first map with the
/// moves of every balance step <= step applied in order.
TerritoryMap map_at(const TerritoryMap& first, const std::vector<BalanceRecord>& log, std::int64_t step);

/// steps.csv: policy,step,world,busy_ms,wait_ms,bodies,cells,lead,islands,
/// cells_out,cells_in,bodies_out,bodies_in (the last four: what the world gave
/// and took at a balance step at the end of this step, 0 at other steps).
void write_steps_csv(std::ostream& out, const LbExperimentResult& r);
/// balance.csv: policy,step,cells_moved,bodies_moved,gather_ms,decide_ms,apply_ms,wall_ms,
/// model_error (the cost model's weighted relative error predicting the worlds'
/// busy time over the period that ended there, out of sample; empty without one).
void write_balance_csv(std::ostream& out, const LbExperimentResult& r);
/// maps.csv: policy,step,x,y,z,owner for every box cell of the map in force
/// at each of `steps`.
void write_maps_csv(std::ostream& out, const LbExperimentResult& r, const std::vector<std::int64_t>& steps);
/// summary.json: the run's description and one object per policy
/// (docs/loadbalance.md lists the fields).
nlohmann::json lb_summary_json(const RunDescription& d, const LbExperimentConfig& config,
                               const LbExperimentResult& r);

}  // namespace soda
