// bench/ — the analytic scenes against their closed forms, each with a fixed
// tolerance whose reason is documented next to it (docs/accuracy.md,
// "Analytic scenes"). Every scene is run on one world and again on the
// partitioned runtime with territory borders across its motion; a partitioned
// run must match the one-territory run bit for bit at every step and pass the
// same checks. Used by tests/accuracy and `soda bench analytic`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "soda/grid/grid.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/run.h"

namespace soda {

struct AnalyticCheck {
  std::string scene;      // free-fall | incline | resting-stack | rolling-sphere
  std::string quantity;   // what is compared
  double measured = 0;    // the error measured (units in `unit`)
  double tolerance = 0;   // pass when measured <= tolerance
  std::string unit;
  bool pass = false;
  std::string reason;     // why this tolerance
  int territories = 1;    // 1: one world; K > 1: the partitioned runtime
  std::string partition;  // K > 1: the partition spec (AnalyticPartition::spec); "" for one world
};

/// A partition of one analytic scene whose borders lie across the scene's
/// motion, and what must happen at those borders: if it does not, the
/// borders were not where the motion is and the run proves nothing.
struct AnalyticPartition {
  std::string scene;
  std::string spec;         // grid:AxBxC, laid over `grid`
  int territories = 1;      // A * B * C
  GridOptions grid;         // cell size, origin and box that put the borders where `borders` says
  std::string borders;      // where the borders lie and how the motion crosses them
  // The mechanism (each a lower bound, over the whole run):
  int min_owners_at_start = 0;   // distinct owners of the dynamic bodies' home cells at step 0
  int min_owners_visited = 0;    // distinct owners of their home cells over all steps
  std::uint64_t min_migrations = 0;      // WorldMetrics::migrations_out, summed over worlds
  std::uint64_t min_ghosts = 0;          // WorldMetrics::ghosts_sent, summed
  std::uint64_t min_border_islands = 0;  // WorldMetrics::islands_solved (border islands solved), summed
};

/// The partitions of docs/accuracy.md, "Analytic scenes": one per scene, in
/// the scenes' order. Pure function.
std::vector<AnalyticPartition> analytic_partitions();

/// One run of one analytic scene and its checks.
struct AnalyticRun {
  std::string scene;
  WorldKind world = WorldKind::Canonical;  // partitioned runs: always the canonical world
  int territories = 1;
  std::string partition;                   // K > 1: spec; "" for one world
  std::string borders;                     // K > 1: where the borders lie
  int steps = 0;
  std::uint64_t state_hash = 0;            // after `steps`
  std::uint64_t one_territory_hash = 0;    // K > 1: the one-territory canonical run's after `steps`;
                                           // one world: state_hash
  // K > 1 only:
  int divergent_steps = 0;       // steps whose state hash differs from the one-territory run's
  int first_divergent_step = -1; // the first of them (-1: none; 0: the initial states)
  int owners_at_start = 1;       // see AnalyticPartition
  int owners_visited = 1;
  WorldMetrics total;            // counters summed over worlds (merged_island_worlds_max: the max)
  bool mechanism_fired = true;   // every lower bound of the AnalyticPartition reached
  std::string mechanism;         // the bounds and the values reached, readable
  std::vector<AnalyticCheck> checks;  // the scene's closed-form checks; K > 1: then the decomposition error
};

/// Runs the four analytic scenes (registry defaults, steps as stated in
/// docs/accuracy.md) on `world` in this build's precision; with
/// `partitioned`, also each on its analytic_partitions() entry (canonical
/// world, Sequential schedule, serialised messages, validation on).
/// Returns the one-world runs in scene order, then the partitioned runs.
/// Deterministic; takes about a second. Throws what PartitionedWorld throws.
std::vector<AnalyticRun> run_analytic(WorldKind world = WorldKind::Canonical, bool partitioned = true);

/// The checks of the one-world runs only (run_analytic(world, false)).
std::vector<AnalyticCheck> run_analytic_checks(WorldKind world = WorldKind::Canonical);

/// Machine epsilon of btScalar (float: 2^-23, double: 2^-52).
double scalar_epsilon();

}  // namespace soda
