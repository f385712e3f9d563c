#include "soda/worlds/solver_pool.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#if defined(SODA_SOLVER_POOL_TBB)
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#endif

namespace soda {
namespace {

// How long a helper keeps polling for the next job before it sleeps: the
// jobs of one coloured solve (one per colour and sweep, a few hundred per
// step) come a few microseconds apart, so a helper that slept between them
// would pay a futex wake-up each time; between solves (collision detection,
// integration) it sleeps and costs nothing. About 20-50 us on this machine.
constexpr int kSpinsBeforeSleep = 4000;
// How long the caller polls before it yields its core (a helper holding a
// task may have been descheduled on a loaded machine).
constexpr int kSpinsBeforeYield = 256;

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#endif
}

template <class Done>
void spin_until(Done done) {
  for (int spins = 0; !done(); ++spins) {
    if (spins < kSpinsBeforeYield) {
      cpu_relax();
    } else {
      std::this_thread::yield();
    }
  }
}

// Wall time, not the thread's CPU clock: a guest visits hundreds of jobs a
// step, and CLOCK_THREAD_CPUTIME_ID is a system call (about a microsecond
// here, the size of a small job's task) where the monotonic clock is not.
// A thread inside a job runs, so the two differ only by preemption.
std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

// The oneTBB build (cmake -DSODA_SOLVER_POOL_TBB=ON; docs/scheduler.md,
// "oneTBB for the coloured solve"): a job is a tbb::parallel_for over its
// tasks in an arena of `threads` slots (the caller's included), no helper
// of the pool's own and no guests. Measurement only: the TSan build never
// sets it (libtbb is not built with ThreadSanitizer).
#if defined(SODA_SOLVER_POOL_TBB)
struct SolverPool::Tbb {
  explicit Tbb(int threads) : arena(threads) {}
  tbb::task_arena arena;
};
constexpr bool kTbb = true;
#else
struct SolverPool::Tbb {};
constexpr bool kTbb = false;
#endif

// The oneTBB build takes no guests (serve() returns at once).
SolverPool::SolverPool(int threads, int guest_slots) : guest_slots_(kTbb ? 0 : guest_slots) {
  if (threads < 1) throw std::invalid_argument("SolverPool: threads must be >= 1");
  if (guest_slots < 0) throw std::invalid_argument("SolverPool: guest_slots must be >= 0");
  block_ = std::make_unique<Block[]>(static_cast<std::size_t>(threads + guest_slots));
#if defined(SODA_SOLVER_POOL_TBB)
  tbb_ = std::make_unique<Tbb>(threads);
  tbb_threads_ = threads;
  return;
#endif
  helpers_.reserve(static_cast<std::size_t>(threads - 1));
  for (int i = 0; i + 1 < threads; ++i) helpers_.emplace_back([this, i] { helper_loop(i + 1); });
}

SolverPool::~SolverPool() {
  stop_.store(true, std::memory_order_seq_cst);
  generation_.fetch_add(1, std::memory_order_seq_cst);
  generation_.notify_all();
  wake_guests();
  for (std::thread& t : helpers_) t.join();
}

int SolverPool::work(int home) {
  const int blocks = blocks_.load(std::memory_order_relaxed);
  int ran = 0;
  for (int k = 0; k < blocks; ++k) {
    Block& b = block_[static_cast<std::size_t>((home + k) % blocks)];
    for (int i = b.next.fetch_add(1, std::memory_order_relaxed); i < b.end;
         i = b.next.fetch_add(1, std::memory_order_relaxed)) {
      (*task_)(i);
      ++ran;
      finished_.fetch_add(1, std::memory_order_release);
    }
  }
  return ran;
}

int SolverPool::run(int count, const std::function<void(int)>& task) {
  std::unique_lock<std::mutex> lock(submit_, std::try_to_lock);
#if defined(SODA_SOLVER_POOL_TBB)
  if (!lock.owns_lock() || count <= 1 || tbb_threads_ == 1) {
    for (int i = 0; i < count; ++i) task(i);
    return 1;
  }
  tbb_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, count), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i != r.end(); ++i) task(i);
    });
  });
  return tbb_threads_;
#endif
  if (!lock.owns_lock() || count <= 1 || (helpers_.empty() && guests_.load(std::memory_order_seq_cst) == 0)) {
    for (int i = 0; i < count; ++i) task(i);
    return 1;
  }
  // No helper is inside (invariant 1 of the last job): the job may be set.
  task_ = &task;
  const int blocks = std::min(threads(), count);
  for (int b = 0; b < blocks; ++b) {
    block_[static_cast<std::size_t>(b)].next.store(static_cast<int>(static_cast<std::int64_t>(count) * b / blocks),
                                                   std::memory_order_relaxed);
    block_[static_cast<std::size_t>(b)].end = static_cast<int>(static_cast<std::int64_t>(count) * (b + 1) / blocks);
  }
  blocks_.store(blocks, std::memory_order_relaxed);
  finished_.store(0, std::memory_order_relaxed);
  const std::uint64_t g = generation_.fetch_add(1, std::memory_order_seq_cst) + 1;
  if (!helpers_.empty()) generation_.notify_all();
  // A guest that came in after this read sees the job when it looks at
  // generation_ (both seq_cst): it never sleeps through it.
  if (guests_.load(std::memory_order_seq_cst) > 0) {
    guest_epoch_.fetch_add(1, std::memory_order_seq_cst);
    guest_epoch_.notify_all();
  }
  work(0);
  spin_until([&] { return finished_.load(std::memory_order_acquire) == count; });
  // Close the job, then wait for the helpers inside to leave. A helper
  // announces itself (inside_) before it checks closed_, the caller closes
  // before it reads inside_: either the caller sees it and waits, or it
  // sees the job closed and stays out.
  closed_.store(g, std::memory_order_seq_cst);
  spin_until([&] { return inside_.load(std::memory_order_seq_cst) == 0; });
  task_ = nullptr;
  return threads();
}

void SolverPool::helper_loop(int home) {
  std::uint64_t seen = 0;
  for (;;) {
    std::uint64_t g = generation_.load(std::memory_order_acquire);
    for (int spins = 0; g == seen && spins < kSpinsBeforeSleep; ++spins) {
      cpu_relax();
      g = generation_.load(std::memory_order_acquire);
    }
    if (g == seen) {
      generation_.wait(seen, std::memory_order_acquire);
      continue;
    }
    if (stop_.load(std::memory_order_seq_cst)) return;
    seen = g;
    visit(g, home);
  }
}

int SolverPool::visit(std::uint64_t g, int home) {
  inside_.fetch_add(1, std::memory_order_seq_cst);
  int ran = 0;
  if (generation_.load(std::memory_order_seq_cst) == g && closed_.load(std::memory_order_seq_cst) != g) ran = work(home);
  inside_.fetch_sub(1, std::memory_order_release);
  return ran;
}

// A guest visits each job at most once (`joined`), as a helper does, and
// only open ones: a job closed before the guest came is none of its
// business. It spins as a helper does between jobs, then sleeps on
// guest_epoch_, which run() bumps for every job while a guest is in and
// wake_guests() for the guest's own reasons; the epoch is read before
// `until` and generation_, so neither a job nor a wake falls between the
// look and the sleep.
SolverPool::Served SolverPool::serve(const std::atomic<bool>& until) {
  Served served;
  int home = 0;
  // A slot, or wait for one: the thread that holds it may be about to leave
  // (a world woken by its message leaves as its neighbour, which just sent
  // that message, comes to wait; the neighbour must not miss the solve).
  for (;;) {
    const std::uint32_t epoch = guest_epoch_.load(std::memory_order_seq_cst);
    if (guest_slots_ == 0 || until.load(std::memory_order_acquire) || stop_.load(std::memory_order_seq_cst))
      return served;
    int in = guests_.load(std::memory_order_seq_cst);
    if (in < guest_slots_) {
      if (guests_.compare_exchange_weak(in, in + 1, std::memory_order_seq_cst)) {
        // Its home block: that of the slot it took (two guests may share
        // one after comings and goings; only where they start differs).
        home = static_cast<int>(helpers_.size()) + 1 + in;
        break;
      }
      continue;
    }
    guest_epoch_.wait(epoch, std::memory_order_seq_cst);
  }
  served.admitted = true;
  std::uint64_t joined = 0;
  for (;;) {
    const std::uint32_t epoch = guest_epoch_.load(std::memory_order_seq_cst);
    if (until.load(std::memory_order_acquire) || stop_.load(std::memory_order_seq_cst)) break;
    bool woke = false;
    for (int spins = 0; spins < kSpinsBeforeSleep; ++spins) {
      const std::uint64_t g = generation_.load(std::memory_order_seq_cst);
      if (g != joined && closed_.load(std::memory_order_seq_cst) != g) {
        joined = g;
        const std::int64_t t0 = now_ns();
        served.tasks += visit(g, home);
        served.busy_ns += now_ns() - t0;
        spins = 0;
      }
      if (until.load(std::memory_order_acquire)) {
        woke = true;
        break;
      }
      cpu_relax();
    }
    if (woke) break;
    guest_epoch_.wait(epoch, std::memory_order_seq_cst);
  }
  guests_.fetch_sub(1, std::memory_order_seq_cst);
  wake_guests();  // a thread waiting for a slot (no system call if none sleeps)
  return served;
}

void SolverPool::wake_guests() {
  guest_epoch_.fetch_add(1, std::memory_order_seq_cst);
  guest_epoch_.notify_all();
}

}  // namespace soda
