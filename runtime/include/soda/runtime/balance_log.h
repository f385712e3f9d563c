// runtime/ — what load balancing did and what every world measured, per
// scene step: the records a PartitionedWorld keeps (balance_log(),
// step_loads()) for the load-balance experiments (docs/loadbalance.md).
//
// Plain values; no thread safety of their own (read them between step()
// calls, as every readout of a PartitionedWorld).
#pragma once

#include <cstdint>
#include <vector>

#include "soda/loadbalance/cost_model.h"
#include "soda/loadbalance/policy.h"

namespace soda {

/// One balance step (RuntimeOptions::balance): what the policy decided
/// and what deciding and applying it cost. CPU times are the driving
/// thread's (every world is stopped meanwhile, so wall time is about the
/// same); seconds.
struct BalanceRecord {
  std::int64_t step = 0;          // scene step the moves took effect at (every world stood there)
  std::int64_t cells_moved = 0;   // moves.size()
  std::int64_t bodies_moved = 0;  // dynamic bodies whose owner changed: their home cell moved
  /// The moves as the policy returned them (checked: one per cell, from the
  /// cell's owner, to another world). The map at any step is the first map
  /// with the moves of every earlier balance step applied in order.
  std::vector<CellMove> moves;
  double gather_cpu_seconds = 0;  // the whole scene's state and the LoadView
  double decide_cpu_seconds = 0;  // BalancePolicy::decide
  double apply_cpu_seconds = 0;   // the new map and the worlds rebuilt for it (0 without moves)
  double wall_seconds = 0;        // the three together, wall clock
  std::vector<std::int64_t> cells_owned;  // box cells per world after the moves, by id
  /// Per world, by id: cells and dynamic bodies it gave (out) and took (in)
  /// at this balance step. Sums over worlds: cells_moved and bodies_moved.
  std::vector<std::int64_t> cells_out, cells_in, bodies_out, bodies_in;
  /// How well the policy's cost model, fitted before this balance step,
  /// predicted each world's measured busy time over the period that ended
  /// here (out of sample: LoadMonitor::last_prediction). samples 0 for a
  /// policy without a model (churn) or before the model had data.
  CostFitQuality prediction;
};

/// Sums over a balance log.
struct BalanceTotals {
  std::int64_t balance_steps = 0;
  std::int64_t cells_moved = 0;
  std::int64_t bodies_moved = 0;
  double gather_cpu_seconds = 0;
  double decide_cpu_seconds = 0;
  double apply_cpu_seconds = 0;
  double wall_seconds = 0;
  /// gather + decide + apply: the CPU load balancing cost in all.
  double cpu_seconds() const { return gather_cpu_seconds + decide_cpu_seconds + apply_cpu_seconds; }
};

/// The sums of `log`'s records.
BalanceTotals balance_totals(const std::vector<BalanceRecord>& log);

/// One world during one scene step. Work re-done for the step (a rollback's
/// re-run, a SyncTest re-run, a heal) adds to it.
struct WorldStepLoad {
  double busy_seconds = 0;   // thread CPU time of the world's stages for the step (restores included)
  double wait_seconds = 0;   // wall time blocked on its neighbours' messages during the step
  std::int32_t bodies = 0;   // dynamic bodies owned at the end of the step
  std::int32_t cells = 0;    // box cells owned during the step
  std::int32_t lead = 0;     // speculation: internal steps ahead of the commit horizon as the step ended
  std::int32_t islands = 0;  // islands solved here in the step's last substep (merged ones at their root)
};

/// Every world during one scene step.
struct StepLoads {
  std::int64_t step = 0;              // scene step: 1 is the first step of the scene
  std::vector<WorldStepLoad> worlds;  // by world id
};

}  // namespace soda
