#include "embedding/simulation_engine.h"

#include <algorithm>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/transport.h"
#include "soda/rollback/commit_horizon.h"
#include "execution/thread_pinning.h"

namespace soda {

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
  o.keep_states = c.past_inputs;
  o.runtime = c.runtime;
  o.testing = c.testing;
  if (c.runtime.watchdog.response == WatchdogResponse::Heal)
    throw std::invalid_argument("SimulationConfig: watchdog heal is not supported by a Simulation (off or stop)");
  if (c.runtime.balance.policy != "none")
    throw std::invalid_argument(
        "SimulationConfig: load balancing (policy '" + c.runtime.balance.policy +
        "') is not supported by a Simulation yet: a cession is applied at a balance step where every world "
        "stands, and a Simulation's worlds run freely (use PartitionedWorld::step, or `soda run` without "
        "--inputs; docs/loadbalance.md)");
  if (c.past_inputs && c.runtime.validate)
    throw std::invalid_argument("SimulationConfig: past_inputs with validate is not supported (the validator "
                                "cannot follow a rollback yet)");
  if (c.on_contacts && !c.contact_events)
    throw std::invalid_argument("SimulationConfig: on_contacts needs contact_events");
  if (c.runtime.anticipation < 0) throw std::invalid_argument("SimulationConfig: anticipation must be >= 0");
  if (c.runtime.anticipation > 0 && c.buffer_capacity < static_cast<std::size_t>(c.runtime.anticipation) + 3)
    throw std::invalid_argument("SimulationConfig: buffer_capacity (" + std::to_string(c.buffer_capacity) +
                                ") must be >= anticipation + 3 (" + std::to_string(c.runtime.anticipation + 3) +
                                "): entries above the commit horizon cannot be freed, and a full buffer of "
                                "them would stop the world that wrote them");
  return o;
}

}  // namespace

SimulationEngine::SimulationEngine(const Scene& scene, TerritoryMap map, SimulationConfig config)
    : config_(std::move(config)), substeps_(scene.settings.substeps), ledger_(scene) {
  const PartitionedOptions options = partitioned_options(config_, map.world_count());
  set_up(scene, options, std::make_unique<PartitionedWorld>(scene, std::move(map), options), 0);
  start_contact_callback();
}

// A snapshot's scene: its bodies and settings (their states are the
// snapshot's; the census and the ledger need only who is there).
SimulationEngine::SimulationEngine(const SimulationSnapshot& snapshot, TerritoryMap map, SimulationConfig config)
    : config_(std::move(config)), substeps_(snapshot.state.settings.substeps), ledger_(scene_of(snapshot.state)) {
  const PartitionedOptions options = partitioned_options(config_, map.world_count());
  for (BodyId id : snapshot.retired_ids) ledger_.retire(id);
  for (JointId id : snapshot.retired_joint_ids) ledger_.retire_joint(id);
  set_up(scene_of(snapshot.state), options,
         std::make_unique<PartitionedWorld>(snapshot.state, std::move(map), options), snapshot.state.steps_done);
  for (const UserInput& given : snapshot.inputs) {
    if (given.step < snapshot.state.steps_done)
      throw std::invalid_argument("SimulationSnapshot: " + describe(given) + " is older than the snapshot's step " +
                                  std::to_string(snapshot.state.steps_done));
    UserInput in = given;
    ledger_.check(in);
    in.sequence = next_sequence_++;
    ledger_.record(in);
    core->census.record(in);
    inputs_.add(in);
  }
  start_contact_callback();
}

// Reads every step from the first on and hands it over. A world's failure
// ends it (every waiting call reports that); the callback's own exception
// fails the run.
void SimulationEngine::start_contact_callback() {
  if (!config_.on_contacts) return;
  contact_thread_ = std::thread([this, reader = ContactReader(core, config_.on_contacts_persist)]() mutable {
    try {
      while (std::optional<ContactStep> step = reader.read_next()) config_.on_contacts(*step);
    } catch (const SimulationError&) {
    } catch (...) {
      // As a world's error: every thread ends, every waiting call throws it.
      std::lock_guard lock(lifecycle_);
      if (scheduler_) scheduler_->fail(kNoWorld, std::current_exception());
      else fail(kNoWorld, std::current_exception());
    }
  });
}

// The partitioned world `w` of `scene` (built with `options`), at scene step `start`:
// buffers, readers' gate and pins, each world's process attached, the entry
// of step `start` published before any thread runs.
void SimulationEngine::set_up(const Scene& scene, const PartitionedOptions& options,
                              std::unique_ptr<PartitionedWorld> w, std::int64_t start) {
  world = std::move(w);
  const int k = world->world_count();
  schedule = options.schedule;
  threads = schedule == Schedule::ThreadPerWorld ? k : schedule == Schedule::Pool ? options.threads : 1;
  core = std::make_shared<SimulationCore>(scene, k, substeps_, start, config_.buffer_capacity, config_.delta_entries);
  // Frames a rollback may still rewrite are not served; with past inputs
  // readers hold the horizon at the frame they show (simulation_core.h).
  core->horizon = parts().horizon;
  core->gate = config_.runtime.anticipation > 0 || config_.past_inputs;
  core->reader_pins = config_.past_inputs;
  core->contacts = config_.contact_events;
  // As the horizon rises, so do the buffers' commit steps (a world blocked
  // for room cannot raise its own), and readers waiting for a final frame
  // look again.
  // The committed frontier follows it too: a world waiting for its
  // neighbours or for the readers does not report it again itself.
  if (core->gate)
    parts().horizon->set_advance_hook([c = core.get()] {
      const std::int64_t final_step = c->horizon->gvt() / c->substeps;
      const std::int64_t committed = c->horizon->gvt_without_readers() / c->substeps;
      for (std::size_t w = 0; w < c->buffers.size(); ++w) {
        c->buffers[w]->raise_commit_step(final_step - 1);
        const std::int64_t newest = c->buffers[w]->newest_step();
        if (newest >= 0) c->control.published(static_cast<WorldId>(w), std::min(committed, newest));
      }
      c->control.set_final(final_step);
    });
  // Readers hold the horizon: a world begins no step whose entry would not
  // fit in its buffer beside the entries from the final step on (those
  // cannot be freed), so that it never blocks for room on entries a
  // rollback may still rewrite, and always takes that rollback in.
  if (core->reader_pins) core->control.hold_for_readers(static_cast<std::int64_t>(config_.buffer_capacity));
  for (WorldId w = 0; w < k; ++w) {
    TransformBuffer<btScalar>& buffer = *core->buffers[static_cast<std::size_t>(w)];
    parts().process(w).attach({&core->control, &buffer, scene.settings.dt, config_.after_step, &inputs_,
                               [this, w](const WorldSnapshot& state) { rewind_world(w, state); },
                               config_.contact_events});
    // The first frame: the scene as given (or restored).
    const TerritoryWorld& tw = world->world(w);
    TransformEntry<btScalar> entry;
    entry.step = start;
    entry.time = core->time_of(start);
    for (const BodyState& b : tw.owned_states()) entry.poses.push_back(body_pose(b));
    if (config_.contact_events) entry.contacts = reported_contacts(tw, tw.kept_contact_state(), tw.owned_ids());
    buffer.publish(std::move(entry));
    buffer.set_commit_step(start - 1);
  }
}

SimulationSnapshot SimulationEngine::snapshot() const {
  std::lock_guard lock(lifecycle_);
  PartitionedWorld::Internals& in = world->internals();
  const std::int64_t step = world->world(0).steps_done() / substeps_;
  std::vector<WorldSnapshot> parts;
  for (WorldId w = 0; w < world->world_count(); ++w) parts.push_back(world->world(w).part_snapshot());
  SimulationSnapshot out;
  out.state = in.assemble(step, std::move(parts));
  out.inputs = inputs_.from(step);
  out.retired_ids = ledger_.removed_before(step);
  out.retired_joint_ids = ledger_.joints_removed_before(step);
  return out;
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
  {
    std::lock_guard lock(lifecycle_);
    if (!stopped_) {
      stopped_ = true;
      core->control.freeze();
      core->control.request_stop();
      for (auto& b : core->buffers) b->stop();
      core->control.wake();  // worlds parked for room see the stopped buffers
      if (scheduler_) scheduler_->join();
    }
  }
  {
    // Outside lifecycle_: the callback may still be giving inputs. It reads
    // on what was final at the stop, and ends.
    std::lock_guard join(join_);
    if (contact_thread_.joinable() && contact_thread_.get_id() != std::this_thread::get_id()) contact_thread_.join();
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
  if (config_.runtime.anticipation > 0) core->control.wait_published(core->control.limit() / substeps_);
  core->control.wait_all_parked();
}

// The scheduler's error hook: the first error of any world, before the
// scheduler closes the transport and stops its threads.
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
  for (auto& b : core->buffers) b->stop();
}

void SimulationEngine::launch_locked() {
  launched_ = true;
  prepare_thread_pinning();  // also readies the logger for fail()
  Scheduler::Options o;
  o.schedule = schedule;
  o.threads = threads;
  o.pin = config_.runtime.pin;
  o.name = "Simulation";
  o.guest_pool = parts().solver_pool.get();
  scheduler_ = std::make_unique<Scheduler>(std::move(o), parts().task_list(), *parts().transport, &core->control,
                                           [this](WorldId w, std::exception_ptr e) { fail(w, std::move(e)); });
  scheduler_->launch();
}

// --- input -------------------------------------------------------------------

void SimulationEngine::input(UserInput in) {
  std::lock_guard lock(lifecycle_);
  core->control.rethrow_if_failed();
  if (stopped_) throw std::logic_error("Simulation: input after stop()");
  ledger_.check(in);
  if (in.kind == UserInput::Kind::AddBody)
    if (const std::string why = world->add_refusal(in.body); !why.empty())
      throw std::invalid_argument(describe(in) + ": " + why);
  in.sequence = next_sequence_++;
  auto record = [&] {
    ledger_.record(in);
    given_.push_back(in);
  };
  // The validator learns of the input before any world can begin its step.
  // The census hears of an added or removed body before any world can
  // apply it (and publish a frame with or without it).
  auto queue = [&] {
    core->census.record(in);
    inputs_.add(in);
  };
  if (core->control.run_if_future(in.step * substeps_, [&] {
        if (parts().validator) parts().validator->expect(in, substeps_);
        queue();
      })) {
    record();
    return;
  }
  const std::string what = describe(in);
  if (!config_.past_inputs)
    throw std::invalid_argument(what + ": a world has already passed that step (inputs at past steps need "
                                "SimulationConfig::past_inputs)");
  CommitHorizon& horizon = *parts().horizon;
  if (!horizon.try_pin_final(in.step * substeps_))
    throw std::invalid_argument(what + ": older than the commit horizon (step " +
                                std::to_string(horizon.highest_gvt() / substeps_) +
                                "); nothing before it can be changed any more");
  struct Unpin {
    CommitHorizon& h;
    std::int64_t step;
    ~Unpin() { h.unpin(step); }
  } unpin{horizon, in.step * substeps_};
  if (config_.runtime.anticipation > 0) {
    // Speculation: a rollback of every world to the input's step, on the
    // rollback board (docs/rollback.md): each world that has passed it
    // restores it on its own thread and re-runs with the input; nobody is
    // held. Queued first, so that every run of that step sees it.
    queue();
    record();
    // The frontier goes back first: until every world has taken the
    // rollback in, the board's pins keep it from being reported again.
    core->control.rolled_back(in.step * substeps_);
    parts().board->post(in.step * substeps_, in.step * substeps_, kNoWorld);
    core->control.wake();  // one thread for every world may sleep on the control, not on a mailbox
    ++rollbacks_;
    return;
  }
  core->control.hold();
  try {
    core->control.wait_all_held();
    queue();
    record();
    rollback_locked(in.step);
  } catch (...) {
    core->control.release_hold();
    throw;
  }
  ++rollbacks_;
}

// Every world is parked at the hold, nothing of a later step is in flight:
// the state every world keeps at `scene_step`, merged, is what each world
// rebuilds from (on its own thread, rewind_world); late fragments of
// finished merges are dropped from the mailboxes first, while nobody sends.
void SimulationEngine::rollback_locked(std::int64_t scene_step) {
  const int k = world->world_count();
  std::optional<WorldSnapshot> whole = parts().kept_snapshot(scene_step, substeps_);
  if (!whole)
    throw std::logic_error("Simulation: some world no longer keeps step " + std::to_string(scene_step) +
                           " (commit horizon broken)");
  auto state = std::make_shared<const WorldSnapshot>(std::move(*whole));
  for (WorldId w = 0; w < k; ++w)
    while (parts().transport->try_receive(w)) {
    }
  // Every world's mark goes back to the step now, under the input's pin,
  // not when its thread takes the rewind: until then its later entries are
  // still in its buffer, and no reader may take them for final.
  for (WorldId w = 0; w < k; ++w) parts().horizon->report(w, scene_step * substeps_);
  core->control.rewind(scene_step * substeps_, std::move(state));
}

// World w's thread, at the boundary it was held at.
void SimulationEngine::rewind_world(WorldId w, const WorldSnapshot& state) {
  auto fresh = std::make_unique<TerritoryWorld>(state, w, world->world(w).map());
  fresh->set_solver_pool(world->world(w).solver_pool());
  fresh->set_parking(world->world(w).parking());
  core->buffers[static_cast<std::size_t>(w)]->invalidate_from(state.steps_done + 1);
  parts().process(w).rewind(*fresh, state.steps_done);
  parts().worlds[static_cast<std::size_t>(w)] = std::move(fresh);
}

std::int64_t SimulationEngine::commit_horizon_step() const {
  return world->internals().horizon->highest_gvt() / substeps_;
}

std::vector<UserInput> SimulationEngine::input_log() const {
  std::lock_guard lock(lifecycle_);
  std::vector<UserInput> log = given_;
  std::stable_sort(log.begin(), log.end(), [](const UserInput& a, const UserInput& b) { return a.step < b.step; });
  return log;
}

std::uint64_t SimulationEngine::rollbacks() const {
  std::lock_guard lock(lifecycle_);
  return rollbacks_;
}

}  // namespace soda
