// runtime/ — how the worlds' steps are scheduled onto threads. This header:
// Schedule, named by PartitionedOptions (partitioned_world.h) and reported by
// Simulation::schedule() (simulation.h); the scheduler itself is internal
// (docs/scheduler.md). Results never depend on it (tests check); speed does.
//
//   soda::PartitionedOptions o{.schedule = soda::Schedule::Pool, .threads = 2};
//   std::printf("%s\n", soda::schedule_name(sim.schedule()));  // "thread-per-world"
#pragma once

namespace soda {

/// How the worlds' steps are scheduled onto threads.
enum class Schedule {
  Sequential,      // one thread, worlds advanced round-robin (deterministic order)
  ThreadPerWorld,  // one thread per world, blocking on its mailbox
  Pool,            // `threads` workers; a world is a task that parks while it waits
};
const char* schedule_name(Schedule schedule);

}  // namespace soda
