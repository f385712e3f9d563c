// worlds/ — one territory's physics. This header: the pool of threads that
// solves the colours of a large island in parallel (docs/coloured-solve.md).
//
// A pool holds threads - 1 helper threads; the thread that calls run() is
// the last one. A job is `count` tasks run by whichever of these threads
// claims them first: callers must make the result independent of which
// thread runs which task (the coloured solve does: the tasks of one job
// touch disjoint bodies).
//
// Home blocks: a job's tasks are cut into threads() contiguous blocks, and
// each thread claims from its own block first (the caller block 0, helper i
// block i + 1, a guest the block of its slot), then from the others'. The
// jobs of one solve cut their data alike (a colour's runs in id order), so a
// thread keeps meeting the same bodies and their cache lines stay on its
// core instead of crossing to the other at every colour.
//
// Invariants:
//  1. run() returns only once every task of its job has finished and no
//     helper is inside the job (so the job's data may be reused at once); a
//     helper that was slow to wake and finds the job closed stays out (the
//     caller never waits for a helper that has not joined: on a loaded
//     machine it may not be scheduled for a while);
//  2. one job at a time: a caller that finds the pool busy (another world
//     solving on it) runs its tasks alone, on its own thread;
//  3. helpers spin a short while between jobs (the jobs of one solve come
//     back to back) and then sleep; they never run a task outside run();
//  4. guests (threads that are not the pool's: a territory's thread waiting
//     for its neighbours' messages, runtime/src/execution/scheduler.cpp) take tasks by
//     the same protocol as helpers, at most guest_slots at a time, and only
//     inside serve() (a thread finding every slot taken waits there for
//     one); a job counts them in threads() whether or not they
//     come, so nothing a caller sees depends on who was waiting.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace soda {

class SolverPool {
 public:
  /// threads >= 1: the caller of run() plus threads - 1 helpers started here;
  /// guest_slots >= 0: how many other threads may serve() at once. Throws
  /// std::invalid_argument otherwise.
  explicit SolverPool(int threads, int guest_slots = 0);
  /// Stops and joins the helpers. No run() may be in progress.
  ~SolverPool();
  SolverPool(const SolverPool&) = delete;
  SolverPool& operator=(const SolverPool&) = delete;

  /// The threads a job can use (the caller included, guests' slots too).
  int threads() const { return (tbb_threads_ > 0 ? tbb_threads_ : static_cast<int>(helpers_.size()) + 1) + guest_slots_; }
  int guest_slots() const { return guest_slots_; }
  /// Guests inside serve() now (a moment's figure; for tests and reports).
  int guests() const { return guests_.load(std::memory_order_acquire); }

  /// What one serve() did.
  struct Served {
    bool admitted = false;    // took a guest slot (false: `until` came first, or the pool has no slots)
    std::int64_t tasks = 0;   // tasks it ran
    std::int64_t busy_ns = 0;  // wall time inside jobs (the thread runs there: its CPU time but for preemption)
  };
  /// A guest: takes tasks of the jobs run() publishes, on the calling
  /// thread, until `until` is true (set by another thread, which then calls
  /// wake_guests()) or the pool is destroyed. With every guest slot taken
  /// it waits for one (or for `until`); with no slots it returns at once.
  Served serve(const std::atomic<bool>& until);
  /// Wakes every guest to look at its `until` again. Any thread.
  void wake_guests();

  /// Runs task(i) for every i in [0, count) and returns when all are done.
  /// Returns the number of threads that could take tasks: threads(), or 1
  /// when the pool was busy with another caller's job or count <= 1 (then
  /// every task ran on the calling thread, in index order). Thread-safe.
  /// An exception thrown by a task terminates the process (tasks are the
  /// solver's row loops, which do not throw).
  int run(int count, const std::function<void(int)>& task);

 private:
  void helper_loop(int home);
  /// Claims and runs tasks, from block `home` first (mod the job's blocks);
  /// the tasks it ran.
  int work(int home);
  /// One helper's or guest's visit to job `g`: joins it unless it closed.
  int visit(std::uint64_t g, int home);

  // One block of a job's tasks: [next, end) are left to claim.
  struct alignas(64) Block {
    std::atomic<int> next{0};
    int end = 0;
  };

  std::mutex submit_;                          // held by the caller of the current job
  std::atomic<std::uint64_t> generation_{0};   // one more per job; release-publishes the job
  std::atomic<std::uint64_t> closed_{0};       // the last job whose tasks all finished
  std::atomic<bool> stop_{false};
  const std::function<void(int)>* task_ = nullptr;  // the current job (written before generation_)
  std::atomic<int> blocks_{0};                 // blocks of the current job (<= threads())
  std::unique_ptr<Block[]> block_;             // threads() of them
  alignas(64) std::atomic<int> finished_{0};   // tasks of the current job finished
  alignas(64) std::atomic<int> inside_{0};     // helpers inside the current job
  std::vector<std::thread> helpers_;
  // The oneTBB build's arena (SODA_SOLVER_POOL_TBB; null otherwise).
  struct Tbb;
  std::unique_ptr<Tbb> tbb_;
  int tbb_threads_ = 0;
  const int guest_slots_;
  alignas(64) std::atomic<int> guests_{0};          // threads inside serve()
  std::atomic<std::uint32_t> guest_epoch_{0};       // guests sleep on it: one more per job (when guests) and wake
};

}  // namespace soda
