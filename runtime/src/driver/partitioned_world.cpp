// PartitionedWorld: construction, readout, heals and SyncTest. The step
// itself is the world process (world_process.h); which thread advances which
// world when is the scheduler's (scheduler.h).
#include "soda/runtime/partitioned_world.h"

#include <algorithm>
#include <cstring>
#include <thread>

#include "embedding/input_ledger.h"
#include "step/input_queue.h"
#include "step/message_tally.h"
#include "driver/metrics_sums.h"
#include "driver/partitioned_internals.h"
#include "soda/runtime/process_group.h"
#include "soda/worlds/scene_share.h"
#include "soda/worlds/world_snapshot.h"
#include "driver/testing_hooks.h"

namespace soda {

const char* schedule_name(Schedule schedule) {
  switch (schedule) {
    case Schedule::Sequential: return "sequential";
    case Schedule::ThreadPerWorld: return "thread-per-world";
    case Schedule::Pool: return "pool";
  }
  return "unknown";
}

namespace {

// RuntimeOptions::solver_guests resolved: -1, the cores the world
// threads leave free while one waits (one thread per world only; never over
// ranks, whose transport has no wake hook for a serving thread).
int solver_guest_slots(const PartitionedOptions& o, int k) {
  if (o.runtime.solver_guests < -1) throw std::invalid_argument("PartitionedWorld: solver_guests must be >= -1");
  if (o.schedule != Schedule::ThreadPerWorld || o.group || k < 2) return 0;
  if (o.runtime.solver_guests >= 0) return std::min(o.runtime.solver_guests, k - 1);
  // More world threads than cores: a waiting world's core runs another
  // world; a guest spinning for jobs would take it (hotspot 400, K = 8 on
  // 2 cores: wall time 1.36 -> 1.68 s with one guest, docs/coloured-solve.md).
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  if (k > cores) return 0;
  return std::max(0, std::min(k - 1, cores - o.runtime.solver_threads));
}

// What makes each world's process safe (process_options.h), from the
// options; the horizon and the board are the caller's.
ProcessSafety process_safety(const PartitionedOptions& o, const detail::TestingHooks& hooks, int substeps,
                             std::atomic<bool>* fault_fired, FuzzRandom* fuzz) {
  const RuntimeOptions& r = o.runtime;
  if (r.checkpoint_every < 1) throw std::invalid_argument("PartitionedWorld: checkpoint_every must be >= 1");
  if (r.anticipation < 0) throw std::invalid_argument("PartitionedWorld: anticipation must be >= 0");
  if (r.anticipation > 0 && r.watchdog.response == WatchdogResponse::Heal)
    throw std::invalid_argument(
        "PartitionedWorld: speculation (anticipation > 0) and the watchdog's Heal cannot be combined yet");
  ProcessSafety safety;
  safety.watchdog = &r.watchdog;
  safety.fault = hooks.inject_fault;
  safety.fault_fired = fault_fired;
  safety.keep_states = r.watchdog.response == WatchdogResponse::Heal || o.keep_states;
  safety.fuzz = fuzz;
  safety.anticipation = r.anticipation * substeps;
  safety.checkpoint_every = r.checkpoint_every;
  safety.recompute = r.rollback == PartitionedOptions::Rollback::Recompute;
  safety.eager_bets = r.eager_bets;
  safety.skip_idle = r.idle_territories;
  safety.verify_replay = hooks.verify_replay;
  return safety;
}

}  // namespace

PartitionedWorld::PartitionedWorld(const Scene& scene, TerritoryMap map, PartitionedOptions options)
    : options_(std::move(options)), substeps_(scene.settings.substeps), base_substeps_(substeps_) {
  init_from_scene(scene, std::move(map), nullptr);
}

PartitionedWorld::PartitionedWorld(Scene&& scene, TerritoryMap map, PartitionedOptions options)
    : options_(std::move(options)), substeps_(scene.settings.substeps), base_substeps_(substeps_) {
  init_from_scene(scene, std::move(map), &scene);
}

// The map's reach and the inputs' checks come from the whole scene, the
// same on every rank; over ranks the worlds are then built from the rank's
// share, and `owned` (the caller's scene, if it gave it up) is freed first;
// on one process it is freed once the worlds are built.
void PartitionedWorld::init_from_scene(const Scene& scene, TerritoryMap map, Scene* owned) {
  init_balance();
  init_inputs(scene);
  map = map_for_run(scene, map);
  if (!options_.group) {
    build(&scene, map, [&](WorldId w) { return std::make_unique<TerritoryWorld>(scene, w, map); });
    if (owned) *owned = Scene{};  // the worlds hold their own copies
    return;
  }
  const ProcessGroup& group = *options_.group;
  const int k = map.world_count();
  std::vector<BodyId> dynamic;  // validation: every rank's bodies are expected
  if (options_.runtime.validate)
    for (const Body& b : scene.bodies)
      if (!b.is_static) dynamic.push_back(b.id);
  // Cessions move cells between ranks' worlds: a balanced run keeps its
  // meshes and heightfields whole.
  const Scene share = scene_share(scene, map, [&](WorldId w) { return group.rank_of(w, k) == group.rank(); },
                                  options_.runtime.balance.policy == "none" && !options_.balance_policy);
  if (owned) *owned = Scene{};
  build(&share, map, [&](WorldId w) { return std::make_unique<TerritoryWorld>(share, w, map); });
  if (in_->validator) in_->validator->expect_bodies(dynamic);
}

PartitionedWorld::PartitionedWorld(const WorldSnapshot& state, TerritoryMap map, PartitionedOptions options)
    : options_(std::move(options)),
      substeps_(state.settings.substeps),
      base_substeps_(substeps_),
      steps_done_(state.steps_done) {
  if (state.steps_done < 0) throw std::invalid_argument("PartitionedWorld: a snapshot with a negative step count");
  init_balance();
  const Scene scene = scene_of(state);
  init_inputs(scene);
  map = map_for_run(scene, map);
  build(&scene, map, [&](WorldId w) { return std::make_unique<TerritoryWorld>(state, w, map); });
}

// The reach covers the scene, the bodies its inputs add and added_extent.
TerritoryMap PartitionedWorld::map_for_run(const Scene& scene, const TerritoryMap& map) {
  double added = options_.runtime.added_extent;
  for (const UserInput& in : options_.inputs)
    if (in.kind == UserInput::Kind::AddBody) added = std::max(added, 2.0 * in.body.shape.bounding_radius());
  reach_speed_ = run_reach_speed(scene, options_.runtime.reach_speed);
  settings_ = scene.settings;
  return map_with_reach(scene, map, options_.runtime.reach_speed, added);
}

std::string PartitionedWorld::add_refusal(const Body& body) const {
  return reach_refusal(body, settings_, map(), reach_speed_);
}

// PartitionedOptions::inputs: checked in order of step, then of the list,
// as a Simulation's input calls check them, and queued for every world.
void PartitionedWorld::init_inputs(const Scene& scene) {
  if (options_.inputs.empty()) return;
  std::vector<std::size_t> order(options_.inputs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return options_.inputs[a].step < options_.inputs[b].step;
  });
  InputLedger ledger(scene);
  inputs_ = std::make_unique<InputQueue>();
  std::uint64_t sequence = 0;
  for (std::size_t i : order) {
    UserInput in = options_.inputs[i];
    const std::string what = "PartitionedOptions::inputs: input " + std::to_string(i) + " (" + describe(in) + ")";
    if (in.step < steps_done_)
      throw std::invalid_argument(what + ": before the world's first step " + std::to_string(steps_done_));
    try {
      ledger.check(in);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(what + ": " + e.what());
    }
    ledger.record(in);
    in.sequence = sequence++;
    inputs_->add(std::move(in));
  }
}

// The processes' counts are carried (metrics()); the worlds are returned,
// to be destroyed by the caller.
std::vector<std::unique_ptr<TerritoryWorld>> PartitionedWorld::retire() {
  carried_.resize(in_->processes.size());
  for (std::size_t w = 0; w < in_->processes.size(); ++w) {
    const WorldMetrics m = in_->processes[w]->metrics();
    add_replaced_run(carried_[w], m);
    carried_[w].cpu_step_ms.insert(carried_[w].cpu_step_ms.end(), m.cpu_step_ms.begin(), m.cpu_step_ms.end());
    carried_[w].lead.insert(carried_[w].lead.end(), m.lead.begin(), m.lead.end());
  }
  std::vector<std::unique_ptr<TerritoryWorld>> worlds = std::move(in_->worlds);
  in_.reset();
  return worlds;
}

void PartitionedWorld::build(const Scene* scene, const TerritoryMap& map,
                             const std::function<std::unique_ptr<TerritoryWorld>(WorldId)>& make_world) {
  if (options_.schedule == Schedule::Pool && options_.threads < 1)
    throw std::invalid_argument("PartitionedWorld: the pool schedule needs threads >= 1");
  if (substeps_ < 1) throw std::invalid_argument("PartitionedWorld: substeps must be >= 1");
  const int k = map.world_count();
  if (options_.runtime.watchdog.heal_substeps < 1 || options_.runtime.watchdog.max_heals < 0)
    throw std::invalid_argument("PartitionedWorld: watchdog heal_substeps must be >= 1 and max_heals >= 0");
  if (!fault_fired_) fault_fired_ = std::make_shared<std::atomic<bool>>(false);
  if (in_) retire();
  in_ = std::make_unique<Internals>();
  Internals& in = *in_;
  const detail::TestingHooks& hooks = detail::testing_hooks_of(options_);
  in.map = map;
  in.graph = std::make_unique<WorldGraph>(map);
  in.transport = options_.serialise ? make_serialising_transport(k) : make_in_memory_transport(k);
  if (options_.group) {
    check_group_options();
    for (WorldId w = 0; w < k; ++w) options_.group->rank_of(w, k);  // a mapping that does not fit throws
    in.transport = options_.group->make_transport(k, std::move(in.transport));
  }
  if (hooks.fuzz_seed) in.transport = make_fuzzing_transport(std::move(in.transport), hooks.fuzz_seed);
  if (options_.runtime.validate && !scene) throw std::logic_error("PartitionedWorld::build: validation needs the scene");
  const bool gathered = options_.group != nullptr;  // over ranks: validator.h
  in.validator = options_.runtime.validate ? std::make_unique<Validator>(*scene, k, gathered) : nullptr;
  // The inputs still to come (those of earlier steps are in the scene).
  if (in.validator && inputs_)
    for (const UserInput& input : inputs_->from(steps_done_)) in.validator->expect(input, substeps_);
  if (options_.runtime.solver_threads < 1) throw std::invalid_argument("PartitionedWorld: solver_threads must be >= 1");
  const int guests = solver_guest_slots(options_, k);
  if (options_.runtime.solver_threads > 1 || guests > 0)
    in.solver_pool = std::make_shared<SolverPool>(options_.runtime.solver_threads, guests);
  for (WorldId w = 0; w < k; ++w) {
    in.worlds.push_back(make_world(w));
    in.worlds.back()->set_solver_pool(in.solver_pool);
    in.worlds.back()->set_parking(options_.runtime.parking);
  }
  std::unique_ptr<SharedMemoryHorizon> horizon;
  if (options_.group) {
    std::vector<bool> local;  // over ranks: this rank's worlds (the ranks compute GVT together)
    for (WorldId w = 0; w < k; ++w) local.push_back(steps_world(w));
    horizon = std::make_unique<SharedMemoryHorizon>(local, steps_done_ * substeps_);
  } else {
    horizon = std::make_unique<SharedMemoryHorizon>(k, steps_done_ * substeps_);
  }
  SharedMemoryHorizon& shared_horizon = *horizon;
  in.horizon = std::move(horizon);
  // Speculation: a world waiting for the horizon, or told to roll back
  // with every world, is woken by a message to itself.
  auto wake = [t = in.transport.get()](WorldId w) {
    Message m;
    m.from = w;
    m.to = w;
    m.payload = Control{Control::Type::Wake};
    t->send(w, std::move(m));
  };
  in.horizon->set_wake_hook(wake);
  if (hooks.fuzz_seed && !fuzz_) fuzz_ = std::make_shared<FuzzRandom>(hooks.fuzz_seed ^ 0x5A5A5A5A5A5A5A5Aull);
  Process::Safety safety = process_safety(options_, hooks, substeps_, fault_fired_.get(), fuzz_.get());
  safety.horizon = in.horizon.get();
  in.board = std::make_unique<RollbackBoard>(k, *in.horizon, wake);
  safety.board = in.board.get();
  if (options_.group && options_.runtime.anticipation > 0) options_.group->share_rollbacks(shared_horizon, *in.board);
  auto statics = std::make_shared<const std::vector<BodySnapshot>>(in.worlds.front()->static_snapshots());
  for (WorldId w = 0; w < k; ++w) {
    if (safety.anticipation > 0)
      safety.rebuild = [slots = &in.worlds, w, map, statics](const WorldSnapshot& part,
                                                             std::int64_t internal_step) -> TerritoryWorld& {
        WorldSnapshot whole = part;
        whole.bodies.insert(whole.bodies.end(), statics->begin(), statics->end());
        std::sort(whole.bodies.begin(), whole.bodies.end(), [](const BodySnapshot& a, const BodySnapshot& b) {
          return a.description.id < b.description.id;
        });
        auto& slot = (*slots)[static_cast<std::size_t>(w)];
        slot = std::make_unique<TerritoryWorld>(whole, w, map, internal_step, slot.get());
        return *slot;
      };
    in.add_process(std::make_unique<Process>(*in.worlds[static_cast<std::size_t>(w)], *in.transport, *in.graph,
                                             in.validator.get(), w == 0 ? options_.progress : nullptr, substeps_,
                                             hooks.solve_everywhere, safety));
    if (inputs_) {
      Process::Output output;
      output.inputs = inputs_.get();
      in.process(w).attach(output);
    }
  }
}

WorldSnapshot PartitionedWorld::snapshot() const {
  if (options_.group) return gathered_snapshot();
  std::vector<WorldSnapshot> parts;
  for (const auto& w : in_->worlds) parts.push_back(w->part_snapshot());
  return in_->assemble(steps_done_, std::move(parts));
}

PartitionedWorld::~PartitionedWorld() = default;

// With the watchdog's Heal response a bad step does not end the run: the
// worlds are rebuilt from their states at a step every one of them still
// keeps (at or after GVT, at or before the bad step's start), run up to the
// bad step, which is then re-simulated as heal_substeps substeps, and go on.
// Every world's verdict is a function of the whole scene's state, so the
// heals, like the steps, are the same for every partition. Load balancing:
// the worlds run to each balance step, where the cession happens before
// they go on (balance_step.cpp).
void PartitionedWorld::step(int n) {
  if (n < 0) throw std::invalid_argument("PartitionedWorld::step: n must be >= 0");
  const std::int64_t goal = steps_done_ + n;
  while (steps_done_ < goal) {
    try {
      if (balance_due()) balance();
      if (heal_at_ > 0 && steps_done_ == heal_at_ - 1) {
        resimulate_with_substeps();
        continue;
      }
      if (options_.sync_test > 0 && heal_at_ == 0) {
        sync_test_step();
        continue;
      }
      run_to(std::min(heal_at_ > 0 ? heal_at_ - 1 : goal, next_balance_step()));
    } catch (const WatchdogError& e) {
      if (options_.runtime.watchdog.response != WatchdogResponse::Heal) throw;
      if (heal_attempts_ >= options_.runtime.watchdog.max_heals)
        throw WatchdogError(e.step(), e.world(), e.findings(), options_.runtime.watchdog.limits,
                            "self-heal gave up after " + std::to_string(heal_attempts_) + " heals");
      ++heal_attempts_;
      restore_before(e);
    }
  }
}

void PartitionedWorld::run_to(std::int64_t scene_step) {
  const std::int64_t target = scene_step * substeps_;
  for (auto& p : in_->processes) p->set_target(target);
  if (options_.group && in_->validator) {
    // Validating over ranks: the reports are gathered and checked every
    // window of steps, which bounds what a rank holds of them.
    constexpr std::int64_t kValidationWindow = 32;
    for (std::int64_t at = steps_done_; at < scene_step;) {
      at = std::min(scene_step, at + kValidationWindow);
      for (auto& p : in_->processes) p->set_target(at * substeps_);
      run_on_ranks(at * substeps_);
      gather_validation(*options_.group, *in_->validator);
    }
  }
  if (options_.group) {
    if (!in_->validator) run_on_ranks(target);
    steps_done_ = scene_step;
    collect_step_loads();
    return;
  }
  Scheduler::Options o;
  o.schedule = options_.schedule;
  o.threads = options_.threads;
  o.pin = options_.runtime.pin;
  o.guest_pool = in_->solver_pool.get();
  Scheduler(std::move(o), in_->task_list(), *in_->transport, nullptr).run();
  steps_done_ = scene_step;
  collect_step_loads();
}

void PartitionedWorld::restore(WorldSnapshot state) {
  const TerritoryMap map = this->map();  // a copy: the rebuild replaces the worlds
  rebuild(state, map);
}

std::vector<BodyState> PartitionedWorld::body_states() const {
  if (options_.group) return gathered_states();
  std::vector<BodyState> out = in_->worlds.front()->static_states();
  for (const auto& w : in_->worlds) {
    std::vector<BodyState> s = w->owned_states();
    out.insert(out.end(), s.begin(), s.end());
  }
  std::sort(out.begin(), out.end(), [](const BodyState& a, const BodyState& b) { return a.id < b.id; });
  return out;
}

std::uint64_t PartitionedWorld::state_hash() const { return soda::state_hash(body_states()); }

std::size_t PartitionedWorld::sleeping_count() const {
  if (options_.group) return gathered_count(true);
  std::size_t n = 0;
  for (const auto& w : in_->worlds) n += w->sleeping_count();
  return n;
}

std::size_t PartitionedWorld::body_count() const {
  if (options_.group) return in_->worlds.front()->static_count() + gathered_count(false);
  std::size_t n = in_->worlds.front()->static_count();
  for (const auto& w : in_->worlds) n += w->owned_count();
  return n;
}

int PartitionedWorld::world_count() const { return static_cast<int>(in_->worlds.size()); }

const TerritoryWorld& PartitionedWorld::world(WorldId id) const { return *in_->worlds.at(static_cast<std::size_t>(id)); }

const WorldGraph& PartitionedWorld::graph() const { return *in_->graph; }

// Work done by processes replaced at a restore (heal, SyncTest) counts too:
// re-run steps cost what they cost.
std::vector<WorldMetrics> PartitionedWorld::metrics() const {
  std::vector<WorldMetrics> out;
  for (std::size_t w = 0; w < in_->processes.size(); ++w) {
    WorldMetrics m = in_->processes[w]->metrics();
    if (w < carried_.size()) {
      const WorldMetrics& c = carried_[w];
      add_replaced_run(m, c);
      m.cpu_step_ms.insert(m.cpu_step_ms.begin(), c.cpu_step_ms.begin(), c.cpu_step_ms.end());
      m.cpu_step_mean_ms = m.cpu_step_ms.empty() ? 0.0 : m.cpu_seconds * 1e3 / double(m.cpu_step_ms.size());
      if (!c.lead.empty()) {  // lead_max: add_replaced_run
        m.lead.insert(m.lead.begin(), c.lead.begin(), c.lead.end());
        double sum = 0;
        for (std::int32_t l : m.lead) sum += l;
        m.lead_mean = sum / static_cast<double>(m.lead.size());
      }
    }
    out.push_back(std::move(m));
  }
  return options_.group ? gathered_metrics(std::move(out)) : out;
}

std::uint64_t PartitionedWorld::messages_sent() const { return in_->transport->messages_sent(); }
std::uint64_t PartitionedWorld::bytes_sent() const { return in_->transport->bytes_sent(); }

}  // namespace soda
