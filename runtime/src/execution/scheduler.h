// Internal: the one scheduler of the world processes — which thread advances
// which world when. PartitionedWorld::step runs it to a fixed target (threads
// for the call); a Simulation's engine runs it gated by a RunControl
// (long-lived threads, a step limit, wake-ups). Three schedules (Schedule):
//
//   Sequential      one thread, worlds round-robin in id order. When none
//                   can go on it waits for a wake-up (gated: a world at the
//                   limit or waiting for room), else reports a deadlock
//                   naming what every world waits for.
//   ThreadPerWorld  world i's thread: advance; done -> wait for the limit to
//                   rise (gated) or end; buffer full -> wait in
//                   publish_blocking; missing a message -> block on its
//                   mailbox (Transport::receive), or, given a solver pool
//                   with guest slots, serve that pool (SolverPool::serve:
//                   the colours of a merged island its root is solving)
//                   until the mailbox's wake hook says a message came.
//   Pool            T workers share a ready queue. A world runs until it must
//                   wait, then parks: on its mailbox (Transport::park; the
//                   transport's wake hook re-queues it) or, gated, at the
//                   limit or for room (the RunControl's wake hook re-queues
//                   it). Workers are the runtime's own threads: a
//                   tbb::task_arena measured no faster and is invisible to
//                   ThreadSanitizer (docs/scheduler.md).
//
// Invariants:
//  1. A world is advanced by one thread at a time: in the pool a world is
//     either queued, running on one worker, or parked, never two of these.
//  2. No world waits in a way that holds a thread other worlds need: the
//     pool and the round-robin thread park a world instead of blocking.
//  3. The first error of any world wins: it is kept (and passed to the
//     error hook), the transport is closed and the pool stopped, so every
//     thread ends by itself; later errors, and TransportClosed in the other
//     worlds, are dropped.
//  4. A thread ends by itself once its worlds are finished (ungated: done;
//     gated: RunControl::finished) or the run is shut down.
//  5. Ungated, in one process, no schedule hangs: the round-robin thread
//     reports a deadlock when no world can go on; the pool when every
//     worker is idle with no world queued and some world not done (no
//     thread can send the message a parked world waits for); a thread per
//     world when every world's thread has waited on its mailbox, with no
//     message taken, for Options::deadlock_after (none of them computes, so
//     none will send). Each report names what every world waits for and
//     fails the run like a world's error (invariant 3).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "soda/runtime/messages.h"
#include "soda/runtime/partitioned_world.h"

namespace soda {

class RunControl;
class SolverPool;
class Transport;

/// One world as the scheduler sees it (PartitionedWorld::Internals::ProcessTask,
/// partitioned_internals.cpp, adapts the world process). Called by one thread at a time (invariant 1).
class WorldTask {
 public:
  struct Advance {
    bool progressed = false;  // did something; call again
    bool done = false;        // reached its target (or, gated, the limit)
  };
  virtual ~WorldTask() = default;
  /// Runs as far as the messages at hand allow; never blocks.
  virtual Advance advance() = 0;
  /// A message taken from the world's mailbox by the scheduler; the world
  /// may keep it for its next advance(), which the scheduler then calls.
  virtual void deliver(Message message) = 0;
  /// Gated: the world stopped because its transform buffer is full.
  virtual bool waiting_for_room() const = 0;
  /// Gated, a thread of the world's own: waits for room and publishes.
  virtual void publish_blocking() = 0;
  /// Internal steps done.
  virtual std::int64_t steps_done() const = 0;
  /// What the world waits for (deadlock reports).
  virtual std::string waiting_for() const = 0;
  /// Wall time (ns) the world spent blocked on or parked for its mailbox.
  virtual void add_blocked_ns(std::int64_t ns) = 0;
  /// Tasks of other worlds' solves the world's thread ran while it waited
  /// (SolverPool::serve), and the time (ns) it spent inside their jobs: the
  /// world's own work, as far as its load is concerned (busy, not waiting).
  virtual void add_guest_work(std::int64_t tasks, std::int64_t busy_ns) = 0;
};

class Scheduler {
 public:
  struct Options {
    Schedule schedule = Schedule::Sequential;
    int threads = 1;  // Pool: workers (>= 1)
    /// Pin the scheduler's threads to cores (thread_pinning.h): world i's
    /// thread, pool worker i, the round-robin thread as 0.
    bool pin = false;
    /// Names the driver in deadlock reports ("PartitionedWorld", "Simulation").
    std::string name = "PartitionedWorld";
    /// The worlds this process steps, by id (a ProcessGroup's rank:
    /// process_group.h); empty: all. Not with Sequential (whose deadlock
    /// check cannot see messages still on their way from another rank).
    std::vector<bool> local = {};
    /// ThreadPerWorld: a world's thread waiting for a message serves this
    /// pool's jobs meanwhile (SolverPool::serve). Null, or a pool without
    /// guest slots: it blocks on its mailbox. Outlives the scheduler.
    SolverPool* guest_pool = nullptr;
    /// ThreadPerWorld, ungated, one process: how long every world's thread
    /// must have waited on its mailbox, no message taken meanwhile, before
    /// the run fails with a deadlock report (invariant 5).
    std::chrono::milliseconds deadlock_after{10000};
  };
  /// Called once, on the failing thread, with the first error and the world
  /// it came from (kNoWorld if unknown), before the transport is closed.
  using ErrorHook = std::function<void(WorldId, std::exception_ptr)>;

  /// `tasks` (one per world, in world order), `transport` and `control`
  /// (null: ungated, every world runs until done) outlive the scheduler.
  Scheduler(Options options, std::vector<WorldTask*> tasks, Transport& transport, RunControl* control,
            ErrorHook on_error = {});
  /// Joins the threads (launch() without join()).
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  /// Ungated: runs every world until done — Sequential on the caller's
  /// thread, else on threads started and joined here — and rethrows the
  /// first error once every thread has stopped. Once per scheduler.
  void run();
  /// Starts the threads and returns; they end by themselves (invariant 4).
  /// Once per scheduler.
  void launch();
  /// Waits for the threads launch() started; removes the wake hooks. The
  /// caller makes them end first (gated: freeze the limit or shut down).
  void join();
  /// The first error of any world, or null. After join().
  std::exception_ptr error() const;
  /// True once every thread launch() started has ended (any thread).
  bool finished() const { return ended_.load() == launched_; }
  /// A failure from outside the worlds (world kNoWorld: e.g. a Simulation's
  /// contact callback threw), handled as a world's: the first error is
  /// reported to the error hook, the transport closes and every thread
  /// ends. Any thread.
  void fail(WorldId world, std::exception_ptr error);

 private:
  struct Pool;
  void run_sequential();
  void run_world(WorldId world);
  void run_pool_worker(int index);
  /// run_world's wait for a message, serving the guest pool meanwhile.
  Message receive_serving(WorldId world, WorldTask& task);
  bool local(WorldId world) const;
  std::size_t local_count() const;
  /// Invariant 5 applies: ungated, every world in this process.
  bool watches_deadlocks() const;
  /// "<name>: deadlock: [what world 0 waits for] ...".
  std::string deadlock_report() const;
  /// A launched thread ends (run_world, run_pool_worker, run_sequential).
  void thread_ended();
  /// ThreadPerWorld: join()'s watch for invariant 5 until every thread ended.
  void watch_threads();

  const Options options_;
  const std::vector<WorldTask*> tasks_;
  Transport& transport_;
  RunControl* const control_;
  const ErrorHook on_error_;
  std::shared_ptr<Pool> pool_;  // shared with the wake hooks, which may run late
  /// Guests (Options::guest_pool): per world, set by the transport's wake
  /// hook when a message came for it while it was parked serving.
  std::unique_ptr<std::atomic<bool>[]> arrived_;
  std::atomic<bool> closing_{false};  // fail() closed the transport: guests stop serving
  std::vector<std::thread> threads_;
  std::size_t launched_ = 0;          // threads launch() started
  std::atomic<std::size_t> ended_{0};  // ... that have ended
  std::mutex ended_mutex_;             // with ended_cv_: join() waits for ended_ (invariant 5)
  std::condition_variable ended_cv_;
  // ThreadPerWorld (invariant 5): world threads waiting on their mailbox,
  // and messages they have taken from it.
  std::atomic<std::size_t> waiting_{0};
  std::atomic<std::uint64_t> taken_{0};
  mutable std::mutex error_mutex_;
  std::exception_ptr error_;
};

}  // namespace soda
