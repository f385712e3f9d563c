// PartitionedWorld: construction, readout and the three schedules. The step
// itself is the world process (world_process.h); a schedule only decides
// which thread advances which world when.
#include "soda/runtime/partitioned_world.h"

#include <algorithm>
#include <cstring>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

#include <spdlog/spdlog.h>

#include "commit_horizon.h"
#include "rollback_board.h"
#include "soda/worlds/world_snapshot.h"

#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/transport.h"
#include "thread_pinning.h"
#include "validator.h"
#include "world_process.h"

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

// Adds what `m` counted to `t`: counters and times summed, maxima kept.
void add_counts(WorldMetrics& t, const WorldMetrics& m) {
  t.cpu_seconds += m.cpu_seconds;
  t.cpu_step_max_ms = std::max(t.cpu_step_max_ms, m.cpu_step_max_ms);
  t.blocked_seconds += m.blocked_seconds;
  t.buffer_blocked_seconds += m.buffer_blocked_seconds;
  t.entries_published += m.entries_published;
  t.entries_dropped += m.entries_dropped;
  t.border_bodies += m.border_bodies;
  t.ghosts_sent += m.ghosts_sent;
  t.ghosts_received += m.ghosts_received;
  t.manifolds_attached += m.manifolds_attached;
  t.manifolds_seeded += m.manifolds_seeded;
  t.manifolds_returned += m.manifolds_returned;
  t.migrations_out += m.migrations_out;
  t.migrations_in += m.migrations_in;
  t.local_islands += m.local_islands;
  t.border_fragments += m.border_fragments;
  t.merged_islands += m.merged_islands;
  t.islands_solved += m.islands_solved;
  t.merged_island_bodies += m.merged_island_bodies;
  t.merged_island_worlds_sum += m.merged_island_worlds_sum;
  t.merged_island_worlds_max = std::max(t.merged_island_worlds_max, m.merged_island_worlds_max);
  t.relay_messages_sent += m.relay_messages_sent;
  t.relay_messages_received += m.relay_messages_received;
  t.fragments_relayed += m.fragments_relayed;
  t.messages_sent += m.messages_sent;
  t.bets += m.bets;
  t.bets_lost += m.bets_lost;
  t.rollbacks += m.rollbacks;
  t.steps_rolled_back += m.steps_rolled_back;
  t.steps_rejoined += m.steps_rejoined;
  t.bodies_resolved += m.bodies_resolved;
  t.bodies_replayed += m.bodies_replayed;
  t.rollback_cpu_seconds += m.rollback_cpu_seconds;
  t.lead_max = std::max(t.lead_max, m.lead_max);
  t.kept_states_max = std::max(t.kept_states_max, m.kept_states_max);
}

}  // namespace

PartitionedWorld::PartitionedWorld(const Scene& scene, TerritoryMap map, PartitionedOptions options)
    : options_(std::move(options)), substeps_(scene.settings.substeps), base_substeps_(substeps_) {
  map = map_with_reach(scene, map, options_.reach_speed);
  build(scene, map, [&](WorldId w) { return std::make_unique<TerritoryWorld>(scene, w, map); });
}

PartitionedWorld::PartitionedWorld(const WorldSnapshot& state, TerritoryMap map, PartitionedOptions options)
    : options_(std::move(options)),
      substeps_(state.settings.substeps),
      base_substeps_(substeps_),
      steps_done_(state.steps_done) {
  if (state.steps_done < 0) throw std::invalid_argument("PartitionedWorld: a snapshot with a negative step count");
  const Scene scene = scene_of(state);
  map = map_with_reach(scene, map, options_.reach_speed);
  build(scene, map, [&](WorldId w) { return std::make_unique<TerritoryWorld>(state, w, map); });
}

void PartitionedWorld::build(const Scene& scene, const TerritoryMap& map,
                             const std::function<std::unique_ptr<TerritoryWorld>(WorldId)>& make_world) {
  if (options_.schedule == Schedule::Pool && options_.threads < 1)
    throw std::invalid_argument("PartitionedWorld: the pool schedule needs threads >= 1");
  if (substeps_ < 1) throw std::invalid_argument("PartitionedWorld: substeps must be >= 1");
  const int k = map.world_count();
  graph_ = std::make_unique<WorldGraph>(map);
  transport_ = options_.serialise ? make_serialising_transport(k) : make_in_memory_transport(k);
  if (options_.fuzz_seed) transport_ = make_fuzzing_transport(std::move(transport_), options_.fuzz_seed);
  validator_ = options_.validate ? std::make_unique<Validator>(scene, k) : nullptr;
  if (options_.watchdog.heal_substeps < 1 || options_.watchdog.max_heals < 0)
    throw std::invalid_argument("PartitionedWorld: watchdog heal_substeps must be >= 1 and max_heals >= 0");
  if (!fault_fired_) fault_fired_ = std::make_shared<std::atomic<bool>>(false);
  carried_.resize(processes_.size());
  for (std::size_t w = 0; w < processes_.size(); ++w) {
    const WorldMetrics m = processes_[w]->metrics();
    add_counts(carried_[w], m);
    carried_[w].cpu_step_ms.insert(carried_[w].cpu_step_ms.end(), m.cpu_step_ms.begin(), m.cpu_step_ms.end());
  }
  processes_.clear();
  worlds_.clear();
  for (WorldId w = 0; w < k; ++w) worlds_.push_back(make_world(w));
  const bool heal = options_.watchdog.response == WatchdogResponse::Heal || options_.keep_states;
  horizon_ = std::make_unique<SharedMemoryHorizon>(k, steps_done_ * substeps_);
  // Speculation: a world waiting for the horizon, or told to roll back
  // with every world, is woken by a message to itself.
  auto wake = [t = transport_.get()](WorldId w) {
    Message m;
    m.from = w;
    m.to = w;
    m.payload = Control{Control::Type::Wake};
    t->send(w, std::move(m));
  };
  horizon_->set_wake_hook(wake);
  if (options_.fuzz_seed && !fuzz_) fuzz_ = std::make_shared<FuzzRandom>(options_.fuzz_seed ^ 0x5A5A5A5A5A5A5A5Aull);
  Process::Safety safety;
  safety.watchdog = &options_.watchdog;
  safety.fault = options_.inject_fault;
  safety.fault_fired = fault_fired_.get();
  safety.horizon = horizon_.get();
  safety.keep_states = heal;
  safety.fuzz = fuzz_.get();
  safety.anticipation = options_.anticipation * substeps_;
  if (options_.checkpoint_every < 1) throw std::invalid_argument("PartitionedWorld: checkpoint_every must be >= 1");
  safety.checkpoint_every = options_.checkpoint_every;
  safety.recompute = options_.rollback == PartitionedOptions::Rollback::Recompute;
  safety.eager_bets = options_.eager_bets;
  safety.verify_replay = options_.verify_replay;
  board_ = std::make_unique<RollbackBoard>(k, *horizon_, wake);
  safety.board = board_.get();
  if (options_.anticipation < 0) throw std::invalid_argument("PartitionedWorld: anticipation must be >= 0");
  if (options_.anticipation > 0 && options_.watchdog.response == WatchdogResponse::Heal)
    throw std::invalid_argument(
        "PartitionedWorld: speculation (anticipation > 0) and the watchdog's Heal cannot be combined yet");
  auto statics = std::make_shared<const std::vector<BodySnapshot>>(worlds_.front()->static_snapshots());
  for (WorldId w = 0; w < k; ++w) {
    if (safety.anticipation > 0)
      safety.rebuild = [this, w, map, statics](const WorldSnapshot& part, std::int64_t internal_step) -> TerritoryWorld& {
        WorldSnapshot whole = part;
        whole.bodies.insert(whole.bodies.end(), statics->begin(), statics->end());
        std::sort(whole.bodies.begin(), whole.bodies.end(), [](const BodySnapshot& a, const BodySnapshot& b) {
          return a.description.id < b.description.id;
        });
        auto& slot = worlds_[static_cast<std::size_t>(w)];
        slot = std::make_unique<TerritoryWorld>(whole, w, map, internal_step, slot.get());
        return *slot;
      };
    processes_.push_back(std::make_unique<Process>(*worlds_[static_cast<std::size_t>(w)], *transport_, *graph_,
                                                   validator_.get(), w == 0 ? options_.progress : nullptr,
                                                   substeps_, options_.solve_everywhere, safety));
  }
}

WorldSnapshot PartitionedWorld::snapshot() const {
  std::vector<WorldSnapshot> parts;
  for (const auto& w : worlds_) parts.push_back(w->part_snapshot());
  return assemble(steps_done_, std::move(parts));
}

std::optional<WorldSnapshot> PartitionedWorld::kept_snapshot(std::int64_t scene_step) const {
  for (const auto& p : processes_)
    if (!p->kept_state(scene_step)) return std::nullopt;
  std::vector<WorldSnapshot> parts;
  for (const auto& p : processes_) parts.push_back(*p->kept_state(scene_step));
  WorldSnapshot whole = assemble(scene_step, std::move(parts));
  whole.settings.substeps = base_substeps_;  // the boundary may have been kept by a re-simulation
  return whole;
}

// One part per world, all at one boundary, plus the statics -> the whole
// scene's state: bodies by id (one owner each); a pair's contact state may
// be held by one world and kept by its key body's owner, and the copies
// must be identical.
WorldSnapshot PartitionedWorld::assemble(std::int64_t scene_step, std::vector<WorldSnapshot> parts) const {
  WorldSnapshot s;
  s.settings = parts.front().settings;
  s.steps_done = scene_step;
  s.bodies = worlds_.front()->static_snapshots();
  std::vector<ManifoldState> manifolds;
  for (WorldSnapshot& part : parts) {
    s.bodies.insert(s.bodies.end(), std::make_move_iterator(part.bodies.begin()),
                    std::make_move_iterator(part.bodies.end()));
    manifolds.insert(manifolds.end(), std::make_move_iterator(part.manifolds.begin()),
                     std::make_move_iterator(part.manifolds.end()));
  }
  std::sort(s.bodies.begin(), s.bodies.end(), [](const BodySnapshot& a, const BodySnapshot& b) {
    return a.description.id < b.description.id;
  });
  for (std::size_t i = 1; i < s.bodies.size(); ++i)
    if (s.bodies[i].description.id == s.bodies[i - 1].description.id)
      throw std::logic_error("PartitionedWorld::snapshot: body " + std::to_string(s.bodies[i].description.id) +
                             " is owned by two worlds");
  std::stable_sort(manifolds.begin(), manifolds.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return std::make_pair(a.id0, a.id1) < std::make_pair(b.id0, b.id1);
  });
  for (ManifoldState& m : manifolds) {
    if (!s.manifolds.empty() && s.manifolds.back().id0 == m.id0 && s.manifolds.back().id1 == m.id1) {
      if (contact_hash({s.manifolds.back()}) != contact_hash({m}))
        throw std::logic_error("PartitionedWorld::snapshot: two worlds hold different contact states for pair " +
                               std::to_string(m.id0) + "-" + std::to_string(m.id1));
      continue;
    }
    s.manifolds.push_back(std::move(m));
  }
  return s;
}

PartitionedWorld::~PartitionedWorld() = default;

// With the watchdog's Heal response a bad step does not end the run: the
// worlds are rebuilt from their states at a step every one of them still
// keeps (at or after GVT, at or before the bad step's start), run up to the
// bad step, which is then re-simulated as heal_substeps substeps, and go on.
// Every world's verdict is a function of the whole scene's state, so the
// heals, like the steps, are the same for every partition.
void PartitionedWorld::step(int n) {
  if (n < 0) throw std::invalid_argument("PartitionedWorld::step: n must be >= 0");
  const std::int64_t goal = steps_done_ + n;
  while (steps_done_ < goal) {
    try {
      if (heal_at_ > 0 && steps_done_ == heal_at_ - 1) {
        resimulate_with_substeps();
        continue;
      }
      if (options_.sync_test > 0 && heal_at_ == 0) {
        sync_test_step();
        continue;
      }
      run_to(heal_at_ > 0 ? heal_at_ - 1 : goal);
    } catch (const WatchdogError& e) {
      if (options_.watchdog.response != WatchdogResponse::Heal) throw;
      if (heal_attempts_ >= options_.watchdog.max_heals)
        throw WatchdogError(e.step(), e.world(), e.findings(), options_.watchdog.limits,
                            "self-heal gave up after " + std::to_string(heal_attempts_) + " heals");
      ++heal_attempts_;
      restore_before(e);
    }
  }
}

// One step, then back sync_test steps (or as far as kept) and forward again:
// the state must come out bit-identical.
void PartitionedWorld::sync_test_step() {
  if (sync_states_.empty()) sync_states_.push_back(snapshot());
  run_to(steps_done_ + 1);
  WorldSnapshot now = snapshot();
  const WorldSnapshot& back = sync_states_.front();
  const std::int64_t t = steps_done_;
  restore(back);
  run_to(t);
  ++sync_rollbacks_;
  const WorldSnapshot again = snapshot();
  if (serialize(again) != serialize(now)) {
    std::string first = "the contact state";
    for (std::size_t i = 0; i < std::min(now.bodies.size(), again.bodies.size()); ++i) {
      const BodyDynamicState& a = now.bodies[i].state;
      const BodyDynamicState& b = again.bodies[i].state;
      if (std::memcmp(a.origin, b.origin, sizeof a.origin) || std::memcmp(a.basis, b.basis, sizeof a.basis) ||
          std::memcmp(a.linear_velocity, b.linear_velocity, sizeof a.linear_velocity) ||
          std::memcmp(a.angular_velocity, b.angular_velocity, sizeof a.angular_velocity)) {
        first = "body " + std::to_string(now.bodies[i].description.id);
        break;
      }
    }
    throw std::logic_error("SyncTest: step " + std::to_string(t) + " re-run from step " +
                           std::to_string(back.steps_done) + " is not bit-identical (first difference: " + first +
                           ")");
  }
  sync_states_.push_back(std::move(now));
  while (static_cast<int>(sync_states_.size()) > options_.sync_test) sync_states_.pop_front();
}

void PartitionedWorld::run_to(std::int64_t scene_step) {
  const std::int64_t target = scene_step * substeps_;
  for (auto& p : processes_) p->set_target(target);
  switch (options_.schedule) {
    case Schedule::Sequential: run_sequential(target); break;
    case Schedule::ThreadPerWorld: run_thread_per_world(target); break;
    case Schedule::Pool: run_pool(target); break;
  }
  steps_done_ = scene_step;
}

// The worlds stopped wherever they were; the newest step whose state every
// world still keeps, before the bad step, is where they start again.
void PartitionedWorld::restore_before(const WatchdogError& error) {
  std::int64_t r = error.step() - 1;
  std::optional<WorldSnapshot> whole = kept_snapshot(r);
  while (!whole && r > 0) whole = kept_snapshot(--r);
  if (!whole)
    throw WatchdogError(error.step(), error.world(), error.findings(), options_.watchdog.limits,
                        "self-heal found no step every world keeps");
  restore(std::move(*whole));
  sync_states_.clear();
  heal_at_ = error.step();
  spdlog::warn("watchdog: {}; rolling back to step {} to re-simulate step {} with {} substeps", error.what(), r,
               heal_at_, options_.watchdog.heal_substeps);
}

// At the boundary before the bad step: that one step as heal_substeps
// substeps of every world, then the usual step size again.
void PartitionedWorld::resimulate_with_substeps() {
  WorldSnapshot at = snapshot();
  at.settings.substeps = base_substeps_ * options_.watchdog.heal_substeps;
  restore(std::move(at));
  run_to(steps_done_ + 1);
  WorldSnapshot after = snapshot();
  after.settings.substeps = base_substeps_;
  restore(std::move(after));
  healed_steps_.push_back(heal_at_);
  heal_at_ = 0;
}

void PartitionedWorld::restore(WorldSnapshot state) {
  const TerritoryMap map = worlds_.front()->map();  // a copy: build() replaces the worlds
  substeps_ = state.settings.substeps;
  steps_done_ = state.steps_done;
  build(scene_of(state), map, [&](WorldId w) { return std::make_unique<TerritoryWorld>(state, w, map); });
}

// Round-robin in world order: deterministic, single-threaded.
void PartitionedWorld::run_sequential(std::int64_t) {
  for (;;) {
    bool all_done = true, progressed = false;
    for (auto& p : processes_) {
      const Process::Advance a = p->advance();
      progressed = progressed || a.progressed;
      all_done = all_done && a.done;
    }
    if (all_done) return;
    if (!progressed) {
      std::string why = "PartitionedWorld: deadlock:";
      for (auto& p : processes_) why += " [" + p->waiting_for() + "]";
      throw std::logic_error(why);
    }
  }
}

namespace {

// First error of any worker; closes the transport so that every other
// worker stops.
class ErrorSlot {
 public:
  void set(std::exception_ptr e, Transport& transport) {
    {
      std::lock_guard lock(mutex_);
      if (!error_) error_ = e;
    }
    transport.close();
  }
  void rethrow() {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  std::mutex mutex_;
  std::exception_ptr error_;
};

}  // namespace

// One thread per world; a world with nothing to do blocks on its mailbox.
void PartitionedWorld::run_thread_per_world(std::int64_t) {
  ErrorSlot error;
  if (options_.pin) prepare_thread_pinning();
  std::vector<std::thread> threads;
  for (std::size_t w = 0; w < processes_.size(); ++w)
    threads.emplace_back([this, w, &error] {
      if (options_.pin) pin_current_thread(static_cast<int>(w), "world " + std::to_string(w));
      Process& p = *processes_[w];
      try {
        for (;;) {
          const Process::Advance a = p.advance();
          if (a.done) return;
          if (a.progressed) continue;
          const std::int64_t t0 = wall_ns();
          Message m = transport_->receive(static_cast<WorldId>(w));
          p.add_blocked_ns(wall_ns() - t0);
          p.deliver(std::move(m));
        }
      } catch (const TransportClosed&) {
        // Another world failed; its error is reported.
      } catch (...) {
        error.set(std::current_exception(), *transport_);
      }
    });
  for (std::thread& t : threads) t.join();
  error.rethrow();
}

// `threads` workers run worlds as tasks: a world runs until it must wait,
// then parks; a message for a parked world puts it back in the ready queue.
void PartitionedWorld::run_pool(std::int64_t) {
  ErrorSlot error;
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<WorldId> ready;
  std::size_t finished = 0;
  bool stop = false;
  for (std::size_t w = 0; w < processes_.size(); ++w) ready.push_back(static_cast<WorldId>(w));
  transport_->set_wake_hook([&](WorldId w) {
    {
      std::lock_guard lock(mutex);
      ready.push_back(w);
    }
    cv.notify_one();
  });
  auto worker = [&](int index) {
    if (options_.pin) pin_current_thread(index, "pool worker " + std::to_string(index));
    for (;;) {
      WorldId w;
      {
        std::unique_lock lock(mutex);
        cv.wait(lock, [&] { return stop || !ready.empty(); });
        if (stop) return;
        w = ready.front();
        ready.pop_front();
      }
      Process& p = *processes_[static_cast<std::size_t>(w)];
      try {
        if (p.parked_at_ns) p.add_blocked_ns(wall_ns() - p.parked_at_ns);
        p.parked_at_ns = 0;
        for (;;) {
          const Process::Advance a = p.advance();
          if (a.done) {
            std::lock_guard lock(mutex);
            if (++finished == processes_.size()) {
              stop = true;
              cv.notify_all();
            }
            break;
          }
          if (a.progressed) continue;
          p.parked_at_ns = wall_ns();
          if (transport_->park(w)) break;  // from here on another worker may run it
          p.parked_at_ns = 0;
        }
      } catch (...) {
        error.set(std::current_exception(), *transport_);
        std::lock_guard lock(mutex);
        stop = true;
        cv.notify_all();
        return;
      }
    }
  };
  if (options_.pin) prepare_thread_pinning();
  std::vector<std::thread> threads;
  for (int i = 0; i < options_.threads; ++i) threads.emplace_back(worker, i);
  for (std::thread& t : threads) t.join();
  transport_->set_wake_hook([](WorldId) {});
  error.rethrow();
}

std::vector<BodyState> PartitionedWorld::body_states() const {
  std::vector<BodyState> out = worlds_.front()->static_states();
  for (const auto& w : worlds_) {
    std::vector<BodyState> s = w->owned_states();
    out.insert(out.end(), s.begin(), s.end());
  }
  std::sort(out.begin(), out.end(), [](const BodyState& a, const BodyState& b) { return a.id < b.id; });
  return out;
}

std::uint64_t PartitionedWorld::state_hash() const { return soda::state_hash(body_states()); }

std::size_t PartitionedWorld::sleeping_count() const {
  std::size_t n = 0;
  for (const auto& w : worlds_) n += w->sleeping_count();
  return n;
}

std::size_t PartitionedWorld::body_count() const {
  std::size_t n = worlds_.front()->static_count();
  for (const auto& w : worlds_) n += w->owned_count();
  return n;
}

int PartitionedWorld::world_count() const { return static_cast<int>(worlds_.size()); }

const TerritoryWorld& PartitionedWorld::world(WorldId id) const { return *worlds_.at(static_cast<std::size_t>(id)); }

// Work done by processes replaced at a restore (heal, SyncTest) counts too:
// re-run steps cost what they cost.
std::vector<WorldMetrics> PartitionedWorld::metrics() const {
  std::vector<WorldMetrics> out;
  for (std::size_t w = 0; w < processes_.size(); ++w) {
    WorldMetrics m = processes_[w]->metrics();
    if (w < carried_.size()) {
      const WorldMetrics& c = carried_[w];
      add_counts(m, c);
      m.cpu_step_ms.insert(m.cpu_step_ms.begin(), c.cpu_step_ms.begin(), c.cpu_step_ms.end());
      m.cpu_step_mean_ms = m.cpu_step_ms.empty() ? 0.0 : m.cpu_seconds * 1e3 / double(m.cpu_step_ms.size());
    }
    out.push_back(std::move(m));
  }
  return out;
}

WorldMetrics total_metrics(const std::vector<WorldMetrics>& worlds) {
  WorldMetrics t;
  double lead_sum = 0;
  std::int64_t steps = 0;
  for (const WorldMetrics& m : worlds) {
    add_counts(t, m);
    t.steps = std::max(t.steps, m.steps);
    t.owned_bodies += m.owned_bodies;
    t.ghosts += m.ghosts;
    t.neighbours += m.neighbours;
    lead_sum += m.lead_mean * static_cast<double>(m.steps);
    steps += m.steps;
  }
  t.cpu_step_max_ms = 0;
  t.lead_mean = steps > 0 ? lead_sum / static_cast<double>(steps) : 0.0;  // weighted by each world's steps
  return t;
}

std::uint64_t PartitionedWorld::messages_sent() const { return transport_->messages_sent(); }
std::uint64_t PartitionedWorld::bytes_sent() const { return transport_->bytes_sent(); }

}  // namespace soda
