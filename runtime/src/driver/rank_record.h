// Internal: `--record` over MPI ranks. Rank 0 writes the replay file; the
// frames come from every rank: after each scene step the ranks send it the
// poses their worlds own, with the owner of each and each world's busy time.
// Also --checkpoint over ranks, and --validate's count of contact pairs.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/replay/view_frame.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/run.h"

namespace soda {

/// Steps `world` (built over config.group's ranks) to config.steps one scene
/// step at a time, and writes frames 0 .. config.steps to
/// config.record_path on rank 0: frame 0 holds `map`, the last one the
/// state hash. Collective: every rank calls it with the same config; only
/// rank 0 passes `header` (the run's view_header; null on the other ranks)
/// and fills r.record_frames, r.record_bytes and r.record_cpu_seconds. The
/// frames are the ones a threaded recording of the run holds, busy times
/// aside (docs/mpi.md, "Recording").
void record_on_ranks(PartitionedWorld& world, const replay::ViewHeader* header, const TerritoryMap& map,
                     const RunConfig& config, RunResult& r);

/// Steps `world` (built over config.group's ranks, at step 0 or at the
/// step config.resume was saved at) to config.checkpoint_at, writes the
/// checkpoint a threaded run writes there to config.checkpoint_path on rank
/// 0 (the gathered snapshot, the `inputs` the run was given that are still
/// to come, the ids retired before the step: config.resume's and those the
/// inputs removed), then steps on to config.steps. Collective: every rank
/// calls it with the same config; a write that fails throws the same
/// CheckpointError on every rank. Fills r.checkpoint_step and, on rank 0,
/// r.checkpoint_bytes.
void checkpoint_on_ranks(PartitionedWorld& world, const std::vector<UserInput>& inputs, const RunConfig& config,
                         RunResult& r);

/// --validate's bodies and contact pairs of `world`, on threads or over
/// config.group's ranks (collective there; rank 0's are the whole scene's).
std::pair<std::size_t, std::size_t> census_counts(const PartitionedWorld& world, const RunConfig& config);

}  // namespace soda
