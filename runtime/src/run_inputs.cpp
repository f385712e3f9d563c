#include "run_inputs.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>

#include <spdlog/spdlog.h>

#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/simulation.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

void check_supported(const RunConfig& config) {
  if (config.world != WorldKind::Canonical)
    throw std::invalid_argument("--inputs runs the canonical world only (not --world stock)");
  if (config.shuffle_seed != 0) throw std::invalid_argument("--inputs cannot be combined with --shuffle-seed");
}

// The API call for one input, as an embedding application makes it.
void give(Simulation& sim, const UserInput& in) {
  const double time = sim.time_of(in.step);
  switch (in.kind) {
    case UserInput::Kind::AddBody: sim.add_body(time, in.body); break;
    case UserInput::Kind::RemoveBody: sim.remove_body(time, in.id); break;
    case UserInput::Kind::SetVelocity: sim.set_velocity(time, in.id, in.linear, in.angular); break;
    case UserInput::Kind::ApplyImpulse: sim.apply_impulse(time, in.id, in.linear); break;
  }
}

}  // namespace

bool inputs_through_simulation(const RunConfig& config) {
  return config.inputs_via_simulation && config.balance.policy == "none" && config.sync_test == 0 &&
         config.watchdog.response != WatchdogResponse::Heal;
}

RunResult run_with_inputs(const Scene& scene, const RunConfig& config) {
  check_supported(config);
  SimulationConfig sc;
  sc.territories = config.territories;
  sc.partition = config.partition;
  sc.threads = config.threads;
  sc.pin = config.pin;
  sc.serialise = config.serialise;
  sc.validate = config.validate;
  sc.anticipation = config.anticipation;
  sc.solver_threads = config.solver_threads;
  sc.rollback = config.rollback;
  sc.checkpoint_every = config.checkpoint_every;
  sc.eager_bets = config.eager_bets;
  sc.watchdog = config.watchdog;
  sc.balance = config.balance;  // a Simulation refuses any policy but "none"
  sc.buffer_capacity = std::max<std::size_t>(sc.buffer_capacity, static_cast<std::size_t>(config.anticipation) + 3);
  // Progress and step times from world 0's thread (re-runs after a rollback
  // included).
  std::vector<std::int64_t> step_ends;
  step_ends.reserve(static_cast<std::size_t>(config.steps));
  std::int64_t t0 = 0, next_progress = 0;
  sc.after_step = [&](WorldId w, std::int64_t step) {
    if (w != 0) return;
    if (config.slow_world0_ms > 0)
      std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(config.slow_world0_ms));
    const std::int64_t now = wall_ns();
    step_ends.push_back(now);
    if (config.progress_seconds > 0 && now >= next_progress) {
      spdlog::info("{} with inputs: world 0 at step {}/{}, {:.1f} s elapsed", scene.name, step, config.steps,
                   static_cast<double>(now - t0) * 1e-9);
      next_progress = now + static_cast<std::int64_t>(config.progress_seconds * 1e9);
    }
  };
  Simulation sim(scene, sc);
  for (const UserInput& in : *config.inputs) {
    try {
      give(sim, in);
    } catch (const std::invalid_argument& e) {
      throw SceneError(config.inputs_source + ": input #" + std::to_string(in.sequence) + " (" +
                       input_kind_name(in.kind) + " at step " + std::to_string(in.step) + "): " + e.what());
    }
  }
  RunResult r;
  r.world = WorldKind::Canonical;
  r.steps = config.steps;
  r.territories = sim.world_count();
  r.partition = config.partition;
  r.schedule = schedule_name(sim.schedule());
  r.threads = sim.thread_count();
  r.anticipation = config.anticipation;
  r.rollback = config.rollback;
  t0 = wall_ns();
  next_progress = t0 + static_cast<std::int64_t>(config.progress_seconds * 1e9);
  sim.advance_to(sim.time_of(config.steps));
  r.wall_seconds = static_cast<double>(wall_ns() - t0) * 1e-9;
  std::vector<std::int64_t> step_ns;
  for (std::size_t i = 0; i < step_ends.size(); ++i) step_ns.push_back(step_ends[i] - (i ? step_ends[i - 1] : t0));
  r.step_time = StepTimeStats::from_ns(std::move(step_ns));
  r.state_hash = sim.state_hash();
  r.sleeping_bodies = sim.sleeping_count();
  r.bodies = sim.body_count();
  r.dynamic_bodies = r.bodies - (scene.bodies.size() - scene.dynamic_count());  // at the end
  r.world_metrics = sim.metrics();
  for (const WorldMetrics& m : r.world_metrics) r.cpu_seconds += m.cpu_seconds;
  sim.stop();
  return r;
}

}  // namespace soda
