// worlds/ — one territory's physics. This header: the pool of threads that
// solves the colours of a large island in parallel (docs/coloured-solve.md).
//
// A pool holds threads - 1 helper threads; the thread that calls run() is
// the last one. A job is `count` tasks run by whichever of these threads
// claims them first: callers must make the result independent of which
// thread runs which task (the coloured solve does: the tasks of one job
// touch disjoint bodies).
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
//     back to back) and then sleep; they never run a task outside run().
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
  /// threads >= 1: the caller of run() plus threads - 1 helpers started here.
  /// Throws std::invalid_argument otherwise.
  explicit SolverPool(int threads);
  /// Stops and joins the helpers. No run() may be in progress.
  ~SolverPool();
  SolverPool(const SolverPool&) = delete;
  SolverPool& operator=(const SolverPool&) = delete;

  /// The threads a job can use (the caller included).
  int threads() const { return static_cast<int>(helpers_.size()) + 1; }

  /// Runs task(i) for every i in [0, count) and returns when all are done.
  /// Returns the number of threads that could take tasks: threads(), or 1
  /// when the pool was busy with another caller's job or count <= 1 (then
  /// every task ran on the calling thread, in index order). Thread-safe.
  /// An exception thrown by a task terminates the process (tasks are the
  /// solver's row loops, which do not throw).
  int run(int count, const std::function<void(int)>& task);

 private:
  void helper_loop();
  void work();

  std::mutex submit_;                          // held by the caller of the current job
  std::atomic<std::uint64_t> generation_{0};   // one more per job; release-publishes the job
  std::atomic<std::uint64_t> closed_{0};       // the last job whose tasks all finished
  std::atomic<bool> stop_{false};
  const std::function<void(int)>* task_ = nullptr;  // the current job (written before generation_)
  std::atomic<int> count_{0};
  alignas(64) std::atomic<int> next_{0};       // next task index to claim
  alignas(64) std::atomic<int> finished_{0};   // tasks of the current job finished
  alignas(64) std::atomic<int> inside_{0};     // helpers inside the current job
  std::vector<std::thread> helpers_;
};

}  // namespace soda
