// Internal: what a Simulation's driver, its world threads and its readers
// share besides the transform buffers — the step limit, wake-ups of parked
// worlds, the published frontier, the stop flag and the first error. One
// mutex; waits block on condition variables.
//
// Invariants (under the mutex):
//  1. The limit (internal steps, a multiple of substeps) only grows until
//     freeze(); after it, it never changes again.
//  2. freeze() sets the limit to the highest step any world has begun
//     (rounded up to a scene step), so every world can reach it and none has
//     gone past it: a stopped run ends with every world at one step boundary.
//  3. published_step() (the newest scene step every world has published)
//     never decreases, except by rewind() (an input at a past step).
//  5. While held, no world begins a step at or past the hold.
//  4. The first fail() wins; after it every wait returns at once.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "soda/runtime/simulation.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {

/// Simulated time at the end of scene step `step` (what entries carry).
inline double scene_time(std::int64_t step, double dt) { return static_cast<double>(step) * dt; }

class RunControl {
 public:
  /// "No limit": far beyond any step count a run can reach.
  static constexpr std::int64_t kUnlimited = std::int64_t{1} << 60;

  /// Every world starts at scene step `start` (a Simulation restored from
  /// a snapshot starts at its step; 0 otherwise), parked there.
  RunControl(int worlds, int substeps, std::int64_t start = 0);

  // --- step limit (internal steps) -----------------------------------------

  /// World thread, before it begins step steps_done + 1: true (and the start
  /// is recorded) if steps_done < limit, the run is not shut down and no
  /// rewind is pending for the world; false otherwise (the world is parked).
  bool may_start(WorldId world, std::int64_t steps_done);
  /// World thread with a thread of its own, parked at the limit: waits until
  /// the limit exceeds steps_done (true) or never will (frozen, shut down:
  /// false).
  bool wait_limit_above(WorldId world, std::int64_t steps_done) const;
  /// True once the world at steps_done will never step again (frozen at or
  /// below it, or shut down).
  bool finished(std::int64_t steps_done) const;
  /// Driver: raises the limit (never lowers it). False if frozen.
  bool raise_limit(std::int64_t internal_steps);
  /// Stop: invariant 2. Returns the frozen limit.
  std::int64_t freeze();
  std::int64_t limit() const;
  /// Every world is parked at the current limit.
  bool all_parked() const;
  /// Waits until every world is parked at the current limit; throws the
  /// SimulationError if a world fails first.
  void wait_all_parked() const;

  // --- rollback for input at a past step (SimulationEngine::input) ---------

  /// Runs `add` under the lock if no world has begun the step after
  /// boundary `internal_step` (the input is then in every world's future)
  /// and returns true; false otherwise.
  bool run_if_future(std::int64_t internal_step, const std::function<void()>& add);
  /// Holds every world at the highest boundary any has begun (a scene step):
  /// worlds below it run up to it, none goes past it. Returns it.
  std::int64_t hold();
  /// Waits until every world is parked at the hold; throws the
  /// SimulationError if a world fails first.
  void wait_all_held() const;
  /// Every world restarts at `internal_step` (a rollback) from `state`:
  /// steps begun and published frontiers go back to it, each world gets a
  /// pending rewind (take_rewind), the hold is released, every parked world
  /// is woken.
  void rewind(std::int64_t internal_step, std::shared_ptr<const WorldSnapshot> state);
  /// World thread, at a step boundary: the state to rebuild from if a
  /// rollback is pending for this world (once), else null. Until it takes
  /// it, may_start refuses it every step.
  std::shared_ptr<const WorldSnapshot> take_rewind(WorldId world);
  /// Speculating, an input at boundary `internal_step` was posted as a
  /// rollback of every world (each takes it on its own thread): the
  /// published frontier of every world goes back to it, and a world parked
  /// past it counts as running until it parks again (it is woken and re-runs
  /// the steps), so that advance_to() and the readouts wait for the re-run.
  void rolled_back(std::int64_t internal_step);
  /// Releases the hold without rewinding (the rollback was abandoned).
  void release_hold();

  // --- wake-ups (worlds parked for room or at the limit) --------------------

  std::uint64_t wake_epoch() const;
  /// Bumps the wake epoch (a reader moved a cursor, a buffer was stopped).
  void wake();
  /// Waits until the wake epoch differs from `seen` or the run is shut down.
  void wait_wake(std::uint64_t seen) const;
  /// Called after every bump (wake, raise_limit, freeze, fail), outside the
  /// lock. The pool uses it to re-queue parked worlds.
  void set_wake_hook(std::function<void()> hook);

  // --- watchers (driver, readers) --------------------------------------------

  /// World thread: it published scene step `step`.
  void published(WorldId world, std::int64_t step);
  /// The newest scene step every world has published.
  std::int64_t published_step() const;
  /// Per world, the newest scene step it has published.
  std::vector<std::int64_t> published_steps() const;
  std::uint64_t watch_epoch() const;
  /// Waits until the watch epoch (bumped by published, request_stop, fail)
  /// differs from `seen`.
  void wait_watch(std::uint64_t seen) const;
  // --- readers holding the commit horizon (past inputs) ----------------------

  /// From now on a world at a scene step boundary s does not begin the next
  /// step while s + 1 - final_step() >= `room` (its buffer's capacity): it
  /// parks as at the limit. Before any world runs.
  void hold_for_readers(std::int64_t room);
  /// The newest scene step no rollback can change any more (the commit
  /// horizon's), raised by the engine as the horizon rises: wakes parked
  /// worlds and watchers. Never lowered. Any thread.
  void set_final(std::int64_t scene_step);
  /// If readers hold a world at `steps_done`: the final scene step that lets
  /// it go on; nullopt if they do not hold it.
  std::optional<std::int64_t> held_until(std::int64_t steps_done) const;
  /// Readers hold the commit horizon (hold_for_readers was called).
  bool readers_hold_horizon() const;
  /// Waits until every world published `step` (true), or the run is stopping
  /// (false); throws the SimulationError if a world failed first.
  bool wait_published(std::int64_t step) const;

  // --- stop and errors ---------------------------------------------------------

  void request_stop();
  bool stopping() const;
  /// Records the first error (later ones are dropped) and shuts down: every
  /// wait returns. Returns true for the first.
  bool fail(WorldId world, std::exception_ptr error);
  bool failed() const;
  bool shut_down() const;
  /// Throws (a copy of) the recorded SimulationError, if any.
  void rethrow_if_failed() const;
  std::optional<SimulationError> error() const;
  /// True once the error was thrown to some caller.
  bool error_reported() const;

 private:
  void bump_wake_locked();
  bool all_parked_locked() const;
  bool held_by_readers_locked(std::int64_t steps_done) const;
  std::int64_t highest_boundary_begun_locked() const;
  [[noreturn]] void throw_error_locked() const;
  void call_hook();

  const int substeps_;
  mutable std::mutex mutex_;
  mutable std::condition_variable world_cv_;  // limit, wake epoch, shutdown
  mutable std::condition_variable watch_cv_;  // published, parked, stop, error
  std::int64_t limit_ = 0;
  std::int64_t hold_ = -1;       // >= 0: no world begins a step at or past it
  std::int64_t room_ = 0;        // > 0: readers hold the horizon (hold_for_readers)
  std::int64_t final_ = 0;       // set_final: the newest final scene step
  std::uint64_t rewinds_ = 0;    // bumped by rewind(): wakes wait_limit_above
  bool frozen_ = false;
  std::vector<std::int64_t> started_;   // per world: steps begun
  std::vector<std::int64_t> parked_at_;  // per world: steps done when it parked at the limit; -1 running
  std::vector<std::int64_t> published_;  // per world: newest scene step published
  std::vector<std::shared_ptr<const WorldSnapshot>> rewind_to_;  // per world: pending rewind
  std::uint64_t wake_epoch_ = 0;
  std::uint64_t watch_epoch_ = 0;
  bool stopping_ = false;
  bool shut_down_ = false;
  std::optional<SimulationError> error_;
  mutable bool error_reported_ = false;
  std::function<void()> hook_;
};

}  // namespace soda
