// Internal: `--record` over MPI ranks. Rank 0 writes the replay file; the
// frames come from every rank: after each scene step the ranks send it the
// poses their worlds own, with the owner of each and each world's busy time.
// Also --validate's count of contact pairs over ranks.
#pragma once

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

/// The contact pairs every rank's worlds hold, summed over the ranks (one
/// holder a pair: --validate checks it every step). Collective.
std::size_t held_pairs_on_ranks(const PartitionedWorld& world, ProcessGroup& group);

}  // namespace soda
