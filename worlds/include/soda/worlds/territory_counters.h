// worlds/ — what one territory world counts in one step (TerritoryWorld::
// counters(), reset by predict()). The counts that add up over steps are
// declared once, in SODA_TERRITORY_COUNTERS: that one line gives the field
// here, the field of a run's WorldMetrics (runtime/world_metrics.h) that
// sums it over steps, its place in the sums over worlds, in the gather over
// MPI ranks and its key in the JSON of `soda run` (for_each_counter).
//
// Invariants:
//  1. every field is reset at the start of a step (predict(),
//     begin_idle_step()) and counts that step only;
//  2. a counter's name is the same everywhere it appears: the field here,
//     the WorldMetrics field, the JSON key.
#pragma once

#include <cstddef>
#include <cstdint>

namespace soda {

/// How a counter combines: over the steps of one world and over the
/// processes a restore replaced (an earlier part of the same run), and
/// over worlds (total_metrics).
enum class CounterFold {
  Sum,  // added in both
  Max,  // the largest in both
  Now,  // a size now: the newest over steps and processes, added over worlds
};

/// The counts of one step that add up into a run's metrics, one line each:
/// X(type, name, fold, what it counts). Expanded into TerritoryCounters,
/// into WorldMetrics and into for_each_counter.
#define SODA_TERRITORY_COUNTERS(X)                                                                             \
  X(std::uint64_t, border_bodies, Sum, "owned bodies sent as ghosts")                                          \
  X(std::uint64_t, halos_culled, Sum, "owned bodies whose halo's cells were not looked up (border culling)")   \
  X(std::uint64_t, ghosts_sent, Sum, "ghost records sent, summed over neighbours")                             \
  X(std::uint64_t, ghosts_received, Sum, "ghost records received")                                            \
  X(std::uint64_t, manifolds_attached, Sum, "kept manifolds sent with ghosts")                                 \
  X(std::uint64_t, manifolds_seeded, Sum, "held pairs written from a value before narrowphase")                \
  X(std::uint64_t, manifolds_returned, Sum, "kept manifolds of pairs held elsewhere, back from a merged island") \
  X(std::uint64_t, migrations_out, Sum, "bodies that moved to a neighbour")                                    \
  X(std::uint64_t, migrations_in, Sum, "bodies that came from a neighbour")                                    \
  X(std::uint64_t, local_islands, Sum, "awake islands solved in place, lone bodies included")                  \
  X(std::uint64_t, border_fragments, Sum, "fragments of merged islands made here")                             \
  X(std::uint64_t, islands_solved, Sum, "merged islands solved here, as their root")                           \
  X(std::uint64_t, merged_island_bodies, Sum, "bodies of the merged islands solved here")                      \
  X(std::uint64_t, merged_island_bodies_in_place, Sum, "of them, this world's own solved in place (no copy)")  \
  X(std::uint64_t, merged_island_joints, Sum, "joints of the merged islands solved here")                      \
  X(std::uint64_t, merged_island_joints_in_place, Sum, "of them, this world's own solved in place (no copy)")  \
  X(std::uint64_t, coloured_islands, Sum, "islands solved coloured here (docs/coloured-solve.md)")              \
  X(std::uint64_t, substepped_islands, Sum, "islands solved in substeps here, re-solves included")             \
  X(std::uint64_t, statics_loaded, Sum, "fixed statics held from this step on: a halo or a joint beyond the reach") \
  X(std::uint64_t, static_copies, Sum, "copies made of statics not held here, for merged islands solved here") \
  X(int, solver_threads, Max, "most threads a coloured island here could use")

/// Declares one counter of a list as a field.
#define SODA_COUNTER_FIELD(type, name, fold, what) type name = 0;

/// What one world did in one step.
struct TerritoryCounters {
  // Sizes of the step, not added up over steps:
  std::size_t owned_bodies = 0;      // owned bodies at predict(), parked ones included
  std::size_t ghosts = 0;            // ghosts present after apply_ghosts
  std::size_t held_manifolds = 0;    // manifolds with points held here after collide
  std::size_t parked_bodies = 0;     // owned bodies parked outside Bullet's world (set_parking)
  std::size_t islands_replayed = 0;  // islands a replayed step did not solve (set_replay)
  std::size_t bodies_replayed = 0;   // their bodies
  // The counts that add up (SODA_TERRITORY_COUNTERS):
  SODA_TERRITORY_COUNTERS(SODA_COUNTER_FIELD)
};

}  // namespace soda
