// runtime/ — what a world of the partitioned runtime measured over the steps
// run so far (PartitionedWorld::metrics, Simulation::metrics). Its counters
// are declared once, as lines of SODA_TERRITORY_COUNTERS (the territory
// world's, worlds/territory_counters.h) and SODA_PROCESS_COUNTERS (the
// world process's, below): each line is a field here, and for_each_counter
// visits them all, which drives the sums over worlds and over replaced
// processes (total_metrics), the gather over MPI ranks and the JSON of
// `soda run` (key = field name). A new counter is one line in one list.
//
// Invariants:
//  1. every counter is visited by for_each_counter exactly once, with the
//     fold of its line (territory_counters.h, CounterFold);
//  2. the per-stage costs add up: the stages' CPU seconds sum to
//     cpu_seconds exactly (stage.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/runtime/message_traffic.h"
#include "soda/runtime/stage.h"
#include "soda/worlds/territory_counters.h"

namespace soda {

/// The counters a world's process keeps besides the territory world's, one
/// line each: X(type, name, fold, what it measures). Times in seconds.
#define SODA_PROCESS_COUNTERS(X)                                                                               \
  X(double, cpu_seconds, Sum, "thread CPU time spent stepping this world, restores included")                  \
  X(double, thread_cpu_seconds, Sum,                                                                           \
    "CPU time of the world's own thread from its first stage to its last finished step, scheduler included "   \
    "(a thread per world only; else 0)")                                                                       \
  X(double, blocked_seconds, Sum, "wall time waiting for neighbours' messages")                                \
  X(double, buffer_blocked_seconds, Sum, "Simulation only: wall time waiting for room in the transform buffer") \
  X(std::uint64_t, entries_published, Sum, "Simulation only: transform buffer entries published")              \
  X(std::uint64_t, entries_dropped, Sum, "Simulation only: entries that found the buffer full while stopping") \
  X(std::size_t, owned_bodies, Now, "owned bodies at the end")                                                 \
  X(std::size_t, ghosts, Now, "ghosts at the end")                                                             \
  X(std::size_t, statics_held, Now, "static bodies held in the Bullet world at the end (kinematic ones too)")     \
  X(std::size_t, neighbours, Now, "worlds this one exchanges messages with")                                   \
  X(std::uint64_t, merged_islands, Sum, "merged islands this world took part in")                              \
  X(std::uint64_t, merged_island_worlds_sum, Sum, "worlds per merged island, summed")                          \
  X(std::uint64_t, merged_island_worlds_max, Max, "most worlds in one merged island")                          \
  X(std::uint64_t, relay_messages_sent, Sum, "Fragments and Results messages sent")                            \
  X(std::uint64_t, relay_messages_received, Sum, "merge messages received")                                    \
  X(std::uint64_t, fragments_relayed, Sum, "other worlds' fragments passed on")                                \
  X(std::uint64_t, messages_sent, Sum, "messages of every kind")                                               \
  X(std::uint64_t, idle_steps, Sum, "internal steps skipped idle (RuntimeOptions::idle_territories)")          \
  X(std::uint64_t, guest_tasks, Sum,                                                                           \
    "tasks of other worlds' solves run while waiting (RuntimeOptions::solver_guests; time in stage solve)")    \
  X(std::uint64_t, bets, Sum, "speculation: neighbour messages assumed empty before they arrived")            \
  X(std::uint64_t, bets_lost, Sum, "speculation: bets that were not empty")                                    \
  X(std::uint64_t, rollbacks, Sum, "speculation: times this world restored an earlier step")                   \
  X(std::uint64_t, steps_rolled_back, Sum, "speculation: internal steps discarded by them")                    \
  X(std::uint64_t, steps_rejoined, Sum, "speculation: of them, taken back unchanged (not re-run)")             \
  X(std::uint64_t, bodies_resolved, Sum, "speculation: bodies solved in re-run steps (owned x steps, less replayed)") \
  X(std::uint64_t, bodies_replayed, Sum, "speculation: bodies of re-run steps whose islands were replayed")    \
  X(double, rollback_cpu_seconds, Sum, "speculation: thread CPU time of restores and re-run steps")             \
  X(std::int64_t, lead_max, Max, "speculation: most internal steps ahead of the commit horizon")               \
  X(std::size_t, kept_states_max, Max, "most states kept at once (rollback buffer occupancy)")

/// Per-world measurements over the steps run so far.
struct WorldMetrics {
  WorldId world = 0;
  std::int64_t steps = 0;  // internal steps
  /// Per stage (stage.h), over the finished internal steps: CPU time (summing
  /// to cpu_seconds exactly), wall time waited, counts; indexed by Stage.
  StageCosts stages = {};
  double cpu_step_mean_ms = 0;      // per internal step
  double cpu_step_max_ms = 0;
  std::vector<double> cpu_step_ms;  // thread CPU time of every internal step, in order
  /// Messages by destination and kind, with their encoded bytes, rounds per
  /// step and merge-tree depths (message_traffic.h), over the finished
  /// internal steps.
  MessageTraffic traffic = {};
  double lead_mean = 0;             // speculation: mean of lead over finished internal steps
  std::vector<std::int32_t> lead;   // speculation: clock - commit horizon at the end of every internal step
  // The counters (for_each_counter): the territory world's, summed over
  // steps (territory_counters.h), then the process's.
  SODA_TERRITORY_COUNTERS(SODA_COUNTER_FIELD)
  SODA_PROCESS_COUNTERS(SODA_COUNTER_FIELD)
};

/// Calls f(name, member, fold) for every counter of WorldMetrics, in the
/// order of the lists: `member` a pointer to the WorldMetrics field (of its
/// own type), `name` its field name, `fold` its CounterFold.
template <class F>
void for_each_counter(F&& f) {
#define SODA_VISIT_COUNTER(type, name, fold, what) f(#name, &WorldMetrics::name, CounterFold::fold);
  SODA_TERRITORY_COUNTERS(SODA_VISIT_COUNTER)
  SODA_PROCESS_COUNTERS(SODA_VISIT_COUNTER)
#undef SODA_VISIT_COUNTER
}

/// f(name, value, fold) for every counter of `m` (WorldMetrics, const or not).
template <class M, class F>
void for_each_counter(M& m, F&& f) {
  for_each_counter([&](const char* name, auto member, CounterFold fold) { f(name, m.*member, fold); });
}

/// The per-world metrics summed over worlds: Sum and Now counters added, Max
/// the largest; steps the most; lead_mean weighted by each world's steps;
/// the per-step series (cpu_step_ms, lead) and cpu_step_mean_ms,
/// cpu_step_max_ms left empty (they do not add up); traffic flows merged by
/// (to, kind).
WorldMetrics total_metrics(const std::vector<WorldMetrics>& worlds);

}  // namespace soda
