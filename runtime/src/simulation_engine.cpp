#include "simulation_engine.h"

#include <condition_variable>
#include <deque>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/transport.h"
#include "thread_pinning.h"

namespace soda {

struct SimulationEngine::Pool {
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<WorldId> ready;
  std::vector<WorldId> parked;  // at the limit or waiting for room
  std::size_t finished = 0;
  bool stop = false;
};

namespace {

PartitionedOptions partitioned_options(const SimulationConfig& c, int k) {
  if (c.threads < 0) throw std::invalid_argument("SimulationConfig: threads must be >= 0");
  if (c.buffer_capacity < 2)
    throw std::invalid_argument("SimulationConfig: buffer_capacity must be >= 2 (a reader keeps the entry at its "
                                "cursor; the writer needs one more)");
  PartitionedOptions o;
  o.schedule = c.threads == 1 ? Schedule::Sequential
               : (c.threads == 0 || c.threads >= k) ? Schedule::ThreadPerWorld
                                                     : Schedule::Pool;
  o.threads = o.schedule == Schedule::Pool ? c.threads : 0;
  o.serialise = c.serialise;
  o.validate = c.validate;
  o.pin = c.pin;
  return o;
}

}  // namespace

SimulationEngine::SimulationEngine(const Scene& scene, TerritoryMap map, SimulationConfig config)
    : config_(std::move(config)), substeps_(scene.settings.substeps) {
  const int k = map.world_count();
  const PartitionedOptions options = partitioned_options(config_, k);
  schedule = options.schedule;
  threads = schedule == Schedule::ThreadPerWorld ? k : schedule == Schedule::Pool ? options.threads : 1;
  world = std::make_unique<PartitionedWorld>(scene, std::move(map), options);
  core = std::make_shared<SimulationCore>(k, substeps_, scene.settings.dt, scene.dynamic_count(),
                                          config_.buffer_capacity);
  for (WorldId w = 0; w < k; ++w) {
    TransformBuffer<btScalar>& buffer = *core->buffers[static_cast<std::size_t>(w)];
    process(w).attach({&core->control, &buffer, scene.settings.dt, config_.after_step});
    // Step 0: the scene as given, published before any thread runs.
    TransformEntry<btScalar> entry;
    entry.step = 0;
    entry.time = core->time_of(0);
    for (const BodyState& b : world->world(w).owned_states()) entry.poses.push_back(body_pose(b));
    buffer.publish(std::move(entry));
    buffer.set_commit_step(-1);
  }
}

SimulationEngine::~SimulationEngine() {
  const bool reported = core->control.error_reported();
  try {
    stop();
  } catch (const std::exception& e) {
    if (!reported) spdlog::warn("Simulation destroyed after a failure nobody was told of: {}", e.what());
  }
}

void SimulationEngine::start(std::int64_t internal_limit) {
  std::lock_guard lock(lifecycle_);
  core->control.rethrow_if_failed();
  if (stopped_) throw std::logic_error("Simulation: start() or advance_to() after stop()");
  core->control.raise_limit(internal_limit);
  if (!launched_) launch_locked();
}

bool SimulationEngine::advance_to(std::int64_t scene_step) {
  {
    std::lock_guard lock(lifecycle_);
    core->control.rethrow_if_failed();
    if (!stopped_) {
      core->control.raise_limit(scene_step >= RunControl::kUnlimited / substeps_ ? RunControl::kUnlimited
                                                                                 : scene_step * substeps_);
      if (!launched_) launch_locked();
    }
  }
  return core->control.wait_published(scene_step);
}

bool SimulationEngine::stopped() const {
  std::lock_guard lock(lifecycle_);
  return stopped_;
}

// Stop: freeze the limit (every world completes the highest step begun),
// release every waiter (buffers stopped: full writers drop their entries),
// join.
void SimulationEngine::stop() {
  std::lock_guard lock(lifecycle_);
  if (!stopped_) {
    stopped_ = true;
    core->control.freeze();
    core->control.request_stop();
    for (auto& b : core->buffers) b->stop();
    core->control.wake();  // worlds parked for room see the stopped buffers
    for (std::thread& t : threads_) t.join();
    threads_.clear();
    core->control.set_wake_hook({});
    if (pool_) world->transport_->set_wake_hook([](WorldId) {});
  }
  core->control.rethrow_if_failed();
}

void SimulationEngine::wait_idle(const char* caller) const {
  {
    std::lock_guard lock(lifecycle_);
    core->control.rethrow_if_failed();
    if (stopped_ || !launched_) return;
  }
  if (core->control.limit() >= RunControl::kUnlimited)
    throw std::logic_error(std::string("Simulation::") + caller +
                           ": the worlds run without a limit (start() without end time); stop() first");
  core->control.wait_all_parked();
}

void SimulationEngine::fail(WorldId w, std::exception_ptr error) {
  if (core->control.fail(w, error)) {
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      spdlog::debug("world {} failed: {}", w, e.what());
    } catch (...) {
      spdlog::debug("world {} failed", w);
    }
  }
  world->transport_->close();
  for (auto& b : core->buffers) b->stop();
  if (pool_) {
    std::lock_guard lock(pool_->mutex);
    pool_->stop = true;
    pool_->cv.notify_all();
  }
}

void SimulationEngine::launch_locked() {
  launched_ = true;
  prepare_thread_pinning();  // also readies the logger for fail()
  const int k = world->world_count();
  switch (schedule) {
    case Schedule::ThreadPerWorld:
      for (WorldId w = 0; w < k; ++w) threads_.emplace_back([this, w] { run_world(w); });
      break;
    case Schedule::Sequential: threads_.emplace_back([this] { run_sequential(); }); break;
    case Schedule::Pool: {
      pool_ = std::make_shared<Pool>();
      for (WorldId w = 0; w < k; ++w) pool_->ready.push_back(w);
      std::shared_ptr<Pool> pool = pool_;
      world->transport_->set_wake_hook([pool](WorldId w) {
        {
          std::lock_guard lock(pool->mutex);
          pool->ready.push_back(w);
        }
        pool->cv.notify_one();
      });
      core->control.set_wake_hook([pool] {
        {
          std::lock_guard lock(pool->mutex);
          pool->ready.insert(pool->ready.end(), pool->parked.begin(), pool->parked.end());
          pool->parked.clear();
        }
        pool->cv.notify_all();
      });
      for (int i = 0; i < threads; ++i) threads_.emplace_back([this, i] { run_pool_worker(i); });
      break;
    }
  }
}

// A thread per world: it blocks on whatever it waits for (limit, room in
// its buffer, its mailbox); nobody else needs this thread meanwhile.
void SimulationEngine::run_world(WorldId w) {
  if (config_.pin) pin_current_thread(static_cast<int>(w), "world " + std::to_string(w));
  PartitionedWorld::Process& p = process(w);
  RunControl& control = core->control;
  try {
    for (;;) {
      const PartitionedWorld::Process::Advance a = p.advance();
      if (a.done) {
        if (!control.wait_limit_above(p.steps_done())) return;
        continue;
      }
      if (a.progressed) continue;
      if (p.waiting_for_room()) {
        p.publish_blocking();
        continue;
      }
      const std::int64_t t0 = wall_ns();
      Message m = world->transport_->receive(w);
      p.add_blocked_ns(wall_ns() - t0);
      p.deliver(std::move(m));
    }
  } catch (const TransportClosed&) {
    // Another world failed; its error is reported.
  } catch (...) {
    fail(w, std::current_exception());
  }
}

// One thread, worlds round-robin. A world waiting for room or parked at the
// limit must not hold the others up: the thread goes on with them, and
// sleeps only when none can go on, until a wake-up (a reader moved, the
// limit rose, a stop).
void SimulationEngine::run_sequential() {
  if (config_.pin) pin_current_thread(0, "simulation thread");
  RunControl& control = core->control;
  const int k = world->world_count();
  WorldId current = kNoWorld;
  try {
    for (;;) {
      if (control.shut_down()) return;
      const std::uint64_t seen = control.wake_epoch();
      bool all_done = true, progressed = false, room = false;
      for (WorldId w = 0; w < k; ++w) {
        current = w;
        const PartitionedWorld::Process::Advance a = process(w).advance();
        progressed = progressed || a.progressed;
        all_done = all_done && a.done;
        room = room || process(w).waiting_for_room();
      }
      current = kNoWorld;
      if (all_done && control.finished(process(0).steps_done())) return;
      if (progressed) continue;
      if (all_done || room) {
        control.wait_wake(seen);
        continue;
      }
      std::string why = "Simulation: deadlock:";
      for (WorldId w = 0; w < k; ++w) why += " [" + process(w).waiting_for() + "]";
      throw std::logic_error(why);
    }
  } catch (...) {
    fail(current, std::current_exception());
  }
}

// A worker runs a world until it must wait. Waiting for a message parks it
// on the transport; waiting for room or for the limit parks it in
// pool.parked, re-queued by the RunControl's wake hook. `seen` closes the
// race with a wake-up between advance() and parking.
void SimulationEngine::run_pool_worker(int index) {
  if (config_.pin) pin_current_thread(index, "pool worker " + std::to_string(index));
  Pool& pool = *pool_;
  RunControl& control = core->control;
  const std::size_t k = static_cast<std::size_t>(world->world_count());
  for (;;) {
    WorldId w;
    std::uint64_t seen;
    {
      std::unique_lock lock(pool.mutex);
      pool.cv.wait(lock, [&] { return pool.stop || !pool.ready.empty(); });
      if (pool.stop) return;
      w = pool.ready.front();
      pool.ready.pop_front();
      seen = control.wake_epoch();
    }
    PartitionedWorld::Process& p = process(w);
    auto park = [&] {
      std::lock_guard lock(pool.mutex);
      if (control.wake_epoch() != seen) {
        pool.ready.push_back(w);
        pool.cv.notify_one();
      } else {
        pool.parked.push_back(w);
      }
    };
    try {
      if (p.parked_at_ns) p.add_blocked_ns(wall_ns() - p.parked_at_ns);
      p.parked_at_ns = 0;
      for (;;) {
        const PartitionedWorld::Process::Advance a = p.advance();
        if (a.done) {
          if (control.finished(p.steps_done())) {
            std::lock_guard lock(pool.mutex);
            if (++pool.finished == k) {
              pool.stop = true;
              pool.cv.notify_all();
            }
          } else {
            park();
          }
          break;
        }
        if (a.progressed) continue;
        if (p.waiting_for_room()) {
          park();
          break;
        }
        p.parked_at_ns = wall_ns();
        if (world->transport_->park(w)) break;  // from here on another worker may run it
        p.parked_at_ns = 0;
      }
    } catch (const TransportClosed&) {
      return;
    } catch (...) {
      fail(w, std::current_exception());
      return;
    }
  }
}

}  // namespace soda
