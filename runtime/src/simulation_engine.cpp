#include "simulation_engine.h"

#include <condition_variable>
#include <deque>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/transport.h"
#include "commit_horizon.h"
#include "soda/scene/validate.h"
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
  o.keep_states = c.past_inputs;
  o.anticipation = c.anticipation;
  o.rollback = c.rollback;
  o.checkpoint_every = c.checkpoint_every;
  o.eager_bets = c.eager_bets;
  o.reach_speed = c.reach_speed;
  if (c.past_inputs && c.validate)
    throw std::invalid_argument("SimulationConfig: past_inputs with validate is not supported (the validator "
                                "cannot follow a rollback yet)");
  if (c.anticipation < 0) throw std::invalid_argument("SimulationConfig: anticipation must be >= 0");
  if (c.anticipation > 0 && c.buffer_capacity < static_cast<std::size_t>(c.anticipation) + 3)
    throw std::invalid_argument("SimulationConfig: buffer_capacity (" + std::to_string(c.buffer_capacity) +
                                ") must be >= anticipation + 3 (" + std::to_string(c.anticipation + 3) +
                                "): entries above the commit horizon cannot be freed, and a full buffer of "
                                "them would stop the world that wrote them");
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
  for (const Body& b : scene.bodies) lives_[b.id] = Life{b.is_static};
  settings_ = scene.settings;
  core = std::make_shared<SimulationCore>(k, substeps_, scene.settings.dt, scene.dynamic_count(),
                                          config_.buffer_capacity);
  for (WorldId w = 0; w < k; ++w) {
    TransformBuffer<btScalar>& buffer = *core->buffers[static_cast<std::size_t>(w)];
    process(w).attach({&core->control, &buffer, scene.settings.dt, config_.after_step, &inputs_,
                       [this, w](const WorldSnapshot& state) { rewind_world(w, state); }});
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
  // Speculation: parked at the limit is not final until the commit horizon
  // reaches it (no rollback can come any more).
  if (config_.anticipation > 0) core->control.wait_published(core->control.limit() / substeps_);
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

// --- input -------------------------------------------------------------------

void SimulationEngine::check_input_locked(const UserInput& in) const {
  const std::string what = describe(in);
  if (in.step < 0) throw std::invalid_argument(what + ": the step must be >= 0");
  if (in.kind == UserInput::Kind::AddBody) {
    if (lives_.count(in.body.id)) throw std::invalid_argument(what + ": id " + std::to_string(in.body.id) + " is in use");
    if (in.body.is_static) throw std::invalid_argument(what + ": only dynamic bodies can be added to a running scene");
    Scene one;
    one.settings = settings_;
    one.bodies.push_back(in.body);
    try {
      validate_scene(one, "added body");
    } catch (const SceneError& e) {
      throw std::invalid_argument(what + ": " + e.what());
    }
    return;
  }
  auto it = lives_.find(in.id);
  if (it == lives_.end()) throw std::invalid_argument(what + ": no body has that id");
  const Life& life = it->second;
  if (life.is_static) throw std::invalid_argument(what + ": the body is static");
  if (in.step < life.added || in.step >= life.removed)
    throw std::invalid_argument(what + ": the body is not in the scene then (added at step " +
                                std::to_string(life.added) +
                                (life.removed == INT64_MAX ? "" : ", removed at step " + std::to_string(life.removed)) +
                                ")");
  if (in.kind == UserInput::Kind::RemoveBody && life.last_input > in.step)
    throw std::invalid_argument(what + ": the body has an input at the later step " + std::to_string(life.last_input));
  if (!in.linear.allFinite() || !in.angular.allFinite())
    throw std::invalid_argument(what + ": velocities and impulses must be finite");
}

void SimulationEngine::input(UserInput in) {
  std::lock_guard lock(lifecycle_);
  core->control.rethrow_if_failed();
  if (stopped_) throw std::logic_error("Simulation: input after stop()");
  check_input_locked(in);
  in.sequence = next_sequence_++;
  auto record = [&] {
    const BodyId id = in.kind == UserInput::Kind::AddBody ? in.body.id : in.id;
    Life& life = lives_[id];
    if (in.kind == UserInput::Kind::AddBody) life.added = in.step;
    if (in.kind == UserInput::Kind::RemoveBody) life.removed = in.step;
    life.last_input = std::max(life.last_input, in.step);
  };
  if (core->control.run_if_future(in.step * substeps_, [&] { inputs_.add(in); })) {
    record();
    return;
  }
  const std::string what = describe(in);
  if (!config_.past_inputs)
    throw std::invalid_argument(what + ": a world has already passed that step (inputs at past steps need "
                                "SimulationConfig::past_inputs)");
  CommitHorizon& horizon = *world->horizon_;
  if (!horizon.try_pin(in.step * substeps_))
    throw std::invalid_argument(what + ": older than the commit horizon (step " + std::to_string(horizon.gvt() / substeps_) +
                                "); nothing before it can be changed any more");
  struct Unpin {
    CommitHorizon& h;
    std::int64_t step;
    ~Unpin() { h.unpin(step); }
  } unpin{horizon, in.step * substeps_};
  if (config_.anticipation > 0) {
    // Speculation: a rollback of every world to the input's step, on the
    // rollback board (docs/rollback.md): each world that has passed it
    // restores it on its own thread and re-runs with the input; nobody is
    // held. Queued first, so that every run of that step sees it.
    inputs_.add(in);
    record();
    world->board_->post(in.step * substeps_, in.step * substeps_, kNoWorld);
    ++rollbacks_;
    return;
  }
  const std::int64_t hold = core->control.hold() / substeps_;
  if (hold - in.step >= static_cast<std::int64_t>(config_.buffer_capacity) - 1) {
    core->control.release_hold();
    throw std::invalid_argument(what + ": " + std::to_string(hold - in.step) +
                                " steps behind the newest world, more than its transform buffer holds (" +
                                std::to_string(config_.buffer_capacity) + ")");
  }
  core->control.wait_all_held();
  inputs_.add(in);
  record();
  rollback_locked(in.step);
  ++rollbacks_;
}

// Every world is parked at the hold, nothing of a later step is in flight:
// the state every world keeps at `scene_step`, merged, is what each world
// rebuilds from (on its own thread, rewind_world); late fragments of
// finished merges are dropped from the mailboxes first, while nobody sends.
void SimulationEngine::rollback_locked(std::int64_t scene_step) {
  const int k = world->world_count();
  std::optional<WorldSnapshot> whole = world->kept_snapshot(scene_step);
  if (!whole)
    throw std::logic_error("Simulation: some world no longer keeps step " + std::to_string(scene_step) +
                           " (commit horizon broken)");
  auto state = std::make_shared<const WorldSnapshot>(std::move(*whole));
  for (WorldId w = 0; w < k; ++w)
    while (world->transport_->try_receive(w)) {
    }
  core->control.rewind(scene_step * substeps_, std::move(state));
}

// World w's thread, at the boundary it was held at.
void SimulationEngine::rewind_world(WorldId w, const WorldSnapshot& state) {
  auto fresh = std::make_unique<TerritoryWorld>(state, w, world->world(w).map());
  core->buffers[static_cast<std::size_t>(w)]->invalidate_from(state.steps_done + 1);
  process(w).rewind(*fresh, state.steps_done);
  world->worlds_[static_cast<std::size_t>(w)] = std::move(fresh);
}

std::int64_t SimulationEngine::commit_horizon_step() const { return world->horizon_->gvt() / substeps_; }

std::uint64_t SimulationEngine::rollbacks() const {
  std::lock_guard lock(lifecycle_);
  return rollbacks_;
}

}  // namespace soda
