// Internal: what the runtime's own drivers use of a PartitionedWorld — its
// worlds, their processes (as scheduler tasks too), the mailboxes and the
// state every world shares (commit horizon, rollback board). Its own step()
// and a Simulation's engine (simulation_engine.h) both run the processes
// through the Scheduler (scheduler.h); the engine also adds inputs and
// rewinds through these parts. Owned by the PartitionedWorld and replaced as
// a whole by a restore (heal, SyncTest): keep no reference across step().
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "soda/rollback/commit_horizon.h"
#include "soda/rollback/rollback_board.h"
#include "execution/scheduler.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/transport.h"
#include "soda/worlds/solver_pool.h"
#include "step/validator.h"
#include "step/world_process.h"

namespace soda {

/// Validation over ranks: the reports every rank's worlds made since the
/// last call, gathered to every rank and checked alike (validator.h).
/// Collective. partitioned_ranks.cpp.
void gather_validation(ProcessGroup& group, Validator& validator);

/// Load balancing over ranks (partitioned_ranks.cpp), collective: each
/// entry summed over the ranks.
std::vector<std::int64_t> summed_over_ranks(ProcessGroup& group, std::vector<std::int64_t> mine);

struct PartitionedWorld::Internals {
  // In construction order; destroyed in reverse (a process refers to all above it).
  TerritoryMap map;  // the map in force (a world kept by a cession may hold an older copy: balance_step.cpp)
  std::unique_ptr<WorldGraph> graph;
  std::unique_ptr<Transport> transport;
  std::unique_ptr<Validator> validator;                 // null unless RuntimeOptions::validate
  std::shared_ptr<SolverPool> solver_pool;              // null unless RuntimeOptions::solver_threads > 1
  std::vector<std::unique_ptr<TerritoryWorld>> worlds;  // by id; a rewind or rollback may replace one
  std::shared_ptr<CommitHorizon> horizon;  // shared with a Simulation's readers
  std::unique_ptr<RollbackBoard> board;                 // speculation: rollbacks of every world
  std::vector<std::unique_ptr<Process>> processes;      // by id
  std::vector<std::unique_ptr<WorldTask>> tasks;        // the processes as the scheduler sees them

  /// World `w`'s process.
  Process& process(WorldId w) { return *processes.at(static_cast<std::size_t>(w)); }
  /// The scheduler's tasks, in world order.
  std::vector<WorldTask*> task_list() const;
  /// Adds world w's process (after the worlds, the transport and the rest).
  void add_process(std::unique_ptr<Process> process);

  /// One part per world, all at one boundary, plus the statics -> the whole
  /// scene's state (PartitionedWorld::snapshot()'s format). Throws
  /// std::logic_error if two worlds own one body or hold different copies of
  /// one pair's contact state.
  WorldSnapshot assemble(std::int64_t scene_step, std::vector<WorldSnapshot> parts) const;
  /// The same with the statics and kinematic bodies given (over ranks: as
  /// the rank that steps world 0 has them) instead of world 0's.
  static WorldSnapshot assemble(std::int64_t scene_step, std::vector<WorldSnapshot> parts,
                                std::vector<BodySnapshot> statics);
  /// The whole scene's state at `scene_step` from the states every world
  /// keeps (PartitionedOptions::keep_states), with `substeps` as its
  /// settings' substeps; nullopt if some world no longer (or not yet) keeps
  /// it. Only while the worlds are stopped or held.
  std::optional<WorldSnapshot> kept_snapshot(std::int64_t scene_step, int substeps) const;

 private:
  class ProcessTask;
};

}  // namespace soda
