#include "execution/scheduler.h"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <optional>
#include <stdexcept>

#include "embedding/run_control.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/transport.h"
#include "soda/worlds/solver_pool.h"
#include "execution/thread_pinning.h"

namespace soda {

// The pool's shared state, under `mutex`. A world is in `ready`, running on
// one worker, parked on the transport, or (gated) in `parked` — one at a time.
struct Scheduler::Pool {
  explicit Pool(std::size_t worlds) : parked_at(worlds, 0) {}
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<WorldId> ready;
  std::vector<WorldId> parked;          // gated: at the limit or waiting for room
  std::vector<std::int64_t> parked_at;  // per world: wall ns it parked on its mailbox; 0: not. Its runner's only.
  std::size_t finished = 0;
  std::size_t idle = 0;  // workers waiting for a queued world
  bool stop = false;
};

Scheduler::Scheduler(Options options, std::vector<WorldTask*> tasks, Transport& transport, RunControl* control,
                     ErrorHook on_error)
    : options_(std::move(options)),
      tasks_(std::move(tasks)),
      transport_(transport),
      control_(control),
      on_error_(std::move(on_error)) {
  if (options_.schedule == Schedule::Pool && options_.threads < 1)
    throw std::invalid_argument("Scheduler: the pool schedule needs threads >= 1");
  if (!options_.local.empty() && options_.local.size() != tasks_.size())
    throw std::invalid_argument("Scheduler: the local-world mask must have one entry per world");
  if (!options_.local.empty() && options_.schedule == Schedule::Sequential)
    throw std::invalid_argument("Scheduler: the sequential schedule steps every world (no local-world mask)");
}

bool Scheduler::local(WorldId world) const {
  return options_.local.empty() || options_.local[static_cast<std::size_t>(world)];
}

std::size_t Scheduler::local_count() const {
  std::size_t n = 0;
  for (WorldId w = 0; w < static_cast<WorldId>(tasks_.size()); ++w) n += local(w) ? 1 : 0;
  return n;
}

Scheduler::~Scheduler() {
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
}

void Scheduler::run() {
  if (options_.schedule == Schedule::Sequential) {
    run_sequential();
  } else {
    launch();
    join();
  }
  if (std::exception_ptr e = error()) std::rethrow_exception(e);
}

void Scheduler::launch() {
  if (options_.pin) prepare_thread_pinning();
  const int k = static_cast<int>(tasks_.size());
  switch (options_.schedule) {
    case Schedule::Sequential:
      threads_.emplace_back([this] {
        if (options_.pin) pin_current_thread(0, "round-robin thread");
        run_sequential();
        thread_ended();
      });
      break;
    case Schedule::ThreadPerWorld:
      if (options_.guest_pool && options_.guest_pool->guest_slots() > 0) {
        arrived_ = std::make_unique<std::atomic<bool>[]>(tasks_.size());
        for (std::size_t w = 0; w < tasks_.size(); ++w) arrived_[w].store(false);
        transport_.set_wake_hook([this](WorldId w) {
          arrived_[static_cast<std::size_t>(w)].store(true, std::memory_order_release);
          options_.guest_pool->wake_guests();
        });
      }
      for (WorldId w = 0; w < k; ++w)
        if (local(w))
          threads_.emplace_back([this, w] {
            run_world(w);
            thread_ended();
          });
      break;
    case Schedule::Pool: {
      pool_ = std::make_shared<Pool>(tasks_.size());
      pool_->stop = local_count() == 0;  // a rank without worlds
      for (WorldId w = 0; w < k; ++w)
        if (local(w)) pool_->ready.push_back(w);
      transport_.set_wake_hook([pool = pool_](WorldId w) {
        {
          std::lock_guard lock(pool->mutex);
          pool->ready.push_back(w);
        }
        pool->cv.notify_one();
      });
      if (control_)
        control_->set_wake_hook([pool = pool_] {
          {
            std::lock_guard lock(pool->mutex);
            pool->ready.insert(pool->ready.end(), pool->parked.begin(), pool->parked.end());
            pool->parked.clear();
          }
          pool->cv.notify_all();
        });
      for (int i = 0; i < options_.threads; ++i)
        threads_.emplace_back([this, i] {
          run_pool_worker(i);
          thread_ended();
        });
      break;
    }
  }
  launched_ = threads_.size();
}

void Scheduler::thread_ended() {
  {
    std::lock_guard lock(ended_mutex_);
    ++ended_;
  }
  ended_cv_.notify_all();
}

bool Scheduler::watches_deadlocks() const { return !control_ && options_.local.empty(); }

std::string Scheduler::deadlock_report() const {
  std::string why = options_.name + ": deadlock:";
  for (WorldTask* t : tasks_) why += " [" + t->waiting_for() + "]";
  return why;
}

void Scheduler::join() {
  if (options_.schedule == Schedule::ThreadPerWorld && watches_deadlocks()) watch_threads();
  for (std::thread& t : threads_) t.join();
  threads_.clear();
  if (pool_ || arrived_) {
    transport_.set_wake_hook([](WorldId) {});
    if (control_) control_->set_wake_hook({});
  }
}

std::exception_ptr Scheduler::error() const {
  std::lock_guard lock(error_mutex_);
  return error_;
}

// Invariant 3. Only the first error closes the transport, so a
// TransportClosed seen by another world comes after it and is dropped here;
// one with no error before it (nobody else closes the transport) is kept.
void Scheduler::fail(WorldId world, std::exception_ptr error) {
  {
    std::lock_guard lock(error_mutex_);
    if (error_) return;
    error_ = error;
  }
  if (on_error_) on_error_(world, error);
  closing_.store(true, std::memory_order_seq_cst);
  transport_.close();
  if (arrived_) {  // serving worlds leave the pool and find the transport closed
    for (std::size_t w = 0; w < tasks_.size(); ++w) arrived_[w].store(true, std::memory_order_seq_cst);
    options_.guest_pool->wake_guests();
  }
  if (pool_) {
    {
      std::lock_guard lock(pool_->mutex);
      pool_->stop = true;
    }
    pool_->cv.notify_all();
  }
}

// Invariant 5 for a thread per world, on the joining thread: every world's
// thread has waited on its mailbox for deadlock_after with no message taken.
// Reading the worlds then is safe: each published its state with its
// increment of waiting_ (read here with acquire) and none runs.
void Scheduler::watch_threads() {
  const auto tick = std::max(options_.deadlock_after / 10, std::chrono::milliseconds(1));
  std::unique_lock lock(ended_mutex_);
  std::uint64_t seen = taken_.load();
  std::chrono::milliseconds quiet{0};
  while (!ended_cv_.wait_for(lock, tick, [&] { return ended_.load() == launched_; })) {
    const std::uint64_t taken = taken_.load();
    const bool all_wait = waiting_.load() == launched_ - ended_.load();
    quiet = all_wait && taken == seen ? quiet + tick : std::chrono::milliseconds(0);
    seen = taken;
    if (quiet < options_.deadlock_after) continue;
    const std::string why = deadlock_report() + " (every world waited " +
                            std::to_string(options_.deadlock_after.count()) + " ms for a message)";
    lock.unlock();
    fail(kNoWorld, std::make_exception_ptr(std::logic_error(why)));
    return;
  }
}

// Round-robin in world order: deterministic. Gated, a world waiting for room
// or parked at the limit must not hold the others up: the thread goes on
// with them and sleeps only when none can go on, until a wake-up (a reader
// moved, the limit rose, a stop).
void Scheduler::run_sequential() {
  const int k = static_cast<int>(tasks_.size());
  WorldId current = kNoWorld;
  try {
    for (;;) {
      if (control_ && control_->shut_down()) return;
      const std::uint64_t seen = control_ ? control_->wake_epoch() : 0;
      bool all_done = true, progressed = false, room = false;
      for (WorldId w = 0; w < k; ++w) {
        current = w;
        const WorldTask::Advance a = tasks_[static_cast<std::size_t>(w)]->advance();
        progressed = progressed || a.progressed;
        all_done = all_done && a.done;
        room = room || tasks_[static_cast<std::size_t>(w)]->waiting_for_room();
      }
      current = kNoWorld;
      if (all_done && (!control_ || control_->finished(tasks_.front()->steps_done()))) return;
      if (progressed) continue;
      // Readers holding the commit horizon: worlds wait for them to read on
      // (their moving on wakes the control), not for each other.
      if (control_ && (all_done || room || control_->readers_hold_horizon())) {
        control_->wait_wake(seen);
        continue;
      }
      throw std::logic_error(deadlock_report());
    }
  } catch (...) {
    fail(current, std::current_exception());
  }
}

// A thread per world: it blocks on whatever it waits for (the limit, room in
// its buffer, its mailbox); nobody else needs this thread meanwhile.
void Scheduler::run_world(WorldId w) {
  if (options_.pin) pin_current_thread(static_cast<int>(w), "world " + std::to_string(w));
  WorldTask& task = *tasks_[static_cast<std::size_t>(w)];
  try {
    for (;;) {
      const WorldTask::Advance a = task.advance();
      if (a.done) {
        if (!control_ || !control_->wait_limit_above(w, task.steps_done())) return;
        continue;
      }
      if (a.progressed) continue;
      if (task.waiting_for_room()) {
        task.publish_blocking();
        continue;
      }
      // Counted for invariant 5: the increment publishes this world's state
      // to join()'s watch, which reads it only once every world waits.
      waiting_.fetch_add(1);
      std::optional<Message> m;
      try {
        if (arrived_) {
          m = receive_serving(w, task);
        } else {
          const std::int64_t t0 = wall_ns();
          m = transport_.receive(w);
          task.add_blocked_ns(wall_ns() - t0);
        }
      } catch (...) {
        waiting_.fetch_sub(1);
        throw;
      }
      taken_.fetch_add(1);
      waiting_.fetch_sub(1);
      task.deliver(std::move(*m));
    }
  } catch (...) {
    fail(w, std::current_exception());
  }
}

// Park on the mailbox (its next message calls the wake hook: arrived_),
// then serve the pool until then (SolverPool::serve waits for a free guest
// slot if need be). The time spent in the pool's jobs is the world's work,
// not its wait. A closing transport falls back to the plain blocking
// receive, which throws TransportClosed.
Message Scheduler::receive_serving(WorldId w, WorldTask& task) {
  std::atomic<bool>& arrived = arrived_[static_cast<std::size_t>(w)];
  const std::int64_t t0 = wall_ns();
  std::int64_t served_ns = 0;  // time inside the pool's jobs (SolverPool::Served::busy_ns)
  auto waited = [&] { return std::max<std::int64_t>(0, wall_ns() - t0 - served_ns); };
  for (;;) {
    if (std::optional<Message> m = transport_.try_receive(w)) {
      task.add_blocked_ns(waited());
      return std::move(*m);
    }
    arrived.store(false, std::memory_order_seq_cst);
    if (!transport_.park(w)) continue;  // a message is queued
    if (closing_.load(std::memory_order_seq_cst)) break;
    const SolverPool::Served s = options_.guest_pool->serve(arrived);
    served_ns += s.busy_ns;
    if (s.tasks > 0) task.add_guest_work(s.tasks, s.busy_ns);
  }
  Message m = transport_.receive(w);
  task.add_blocked_ns(waited());
  return m;
}

// A worker runs a world until it must wait. Waiting for a message parks it
// on the transport; gated, waiting for room or for the limit parks it in
// pool.parked, re-queued by the RunControl's wake hook. `seen` closes the
// race with a wake-up between advance() and parking.
void Scheduler::run_pool_worker(int index) {
  if (options_.pin) pin_current_thread(index, "pool worker " + std::to_string(index));
  Pool& pool = *pool_;
  for (;;) {
    WorldId w;
    std::uint64_t seen = 0;
    {
      std::unique_lock lock(pool.mutex);
      // Invariant 5: the last worker to go idle with no world queued and
      // some not done. Every world is parked; a parked world's message could
      // only come from a running one.
      if (++pool.idle == static_cast<std::size_t>(options_.threads) && pool.ready.empty() && !pool.stop &&
          pool.finished < local_count() && watches_deadlocks()) {
        const std::string why = deadlock_report();
        --pool.idle;
        lock.unlock();
        fail(kNoWorld, std::make_exception_ptr(std::logic_error(why)));
        return;
      }
      pool.cv.wait(lock, [&] { return pool.stop || !pool.ready.empty(); });
      --pool.idle;
      if (pool.stop) return;
      w = pool.ready.front();
      pool.ready.pop_front();
      if (control_) seen = control_->wake_epoch();
    }
    WorldTask& task = *tasks_[static_cast<std::size_t>(w)];
    std::int64_t& parked_at = pool.parked_at[static_cast<std::size_t>(w)];
    auto park = [&] {
      std::lock_guard lock(pool.mutex);
      if (control_->wake_epoch() != seen) {
        pool.ready.push_back(w);
        pool.cv.notify_one();
      } else {
        pool.parked.push_back(w);
      }
    };
    try {
      if (parked_at) task.add_blocked_ns(wall_ns() - parked_at);
      parked_at = 0;
      for (;;) {
        const WorldTask::Advance a = task.advance();
        if (a.done) {
          if (!control_ || control_->finished(task.steps_done())) {
            std::lock_guard lock(pool.mutex);
            if (++pool.finished == local_count()) {
              pool.stop = true;
              pool.cv.notify_all();
            }
          } else {
            park();
          }
          break;
        }
        if (a.progressed) continue;
        if (task.waiting_for_room()) {
          park();
          break;
        }
        parked_at = wall_ns();
        if (transport_.park(w)) break;  // from here on another worker may run it
        parked_at = 0;
      }
    } catch (...) {
      fail(w, std::current_exception());
      return;
    }
  }
}

}  // namespace soda
