#include "soda/worlds/solver_pool.h"

#include <stdexcept>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
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

}  // namespace

SolverPool::SolverPool(int threads) {
  if (threads < 1) throw std::invalid_argument("SolverPool: threads must be >= 1");
  helpers_.reserve(static_cast<std::size_t>(threads - 1));
  for (int i = 0; i + 1 < threads; ++i) helpers_.emplace_back([this] { helper_loop(); });
}

SolverPool::~SolverPool() {
  stop_.store(true, std::memory_order_seq_cst);
  generation_.fetch_add(1, std::memory_order_seq_cst);
  generation_.notify_all();
  for (std::thread& t : helpers_) t.join();
}

void SolverPool::work() {
  const int count = count_.load(std::memory_order_relaxed);
  for (int i = next_.fetch_add(1, std::memory_order_relaxed); i < count;
       i = next_.fetch_add(1, std::memory_order_relaxed)) {
    (*task_)(i);
    finished_.fetch_add(1, std::memory_order_release);
  }
}

int SolverPool::run(int count, const std::function<void(int)>& task) {
  std::unique_lock<std::mutex> lock(submit_, std::try_to_lock);
  if (!lock.owns_lock() || helpers_.empty() || count <= 1) {
    for (int i = 0; i < count; ++i) task(i);
    return 1;
  }
  // No helper is inside (invariant 1 of the last job): the job may be set.
  task_ = &task;
  count_.store(count, std::memory_order_relaxed);
  finished_.store(0, std::memory_order_relaxed);
  next_.store(0, std::memory_order_relaxed);
  const std::uint64_t g = generation_.fetch_add(1, std::memory_order_seq_cst) + 1;
  generation_.notify_all();
  work();
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

void SolverPool::helper_loop() {
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
    inside_.fetch_add(1, std::memory_order_seq_cst);
    if (generation_.load(std::memory_order_seq_cst) == g && closed_.load(std::memory_order_seq_cst) != g) work();
    inside_.fetch_sub(1, std::memory_order_release);
  }
}

}  // namespace soda
