#include "driver/run_inputs.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>

#include <spdlog/spdlog.h>

#include "soda/grid/partition.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/replay/replay_writer.h"
#include "soda/runtime/simulation.h"
#include "soda/runtime/view_adapter.h"
#include "soda/scene/validate.h"

namespace soda {

void check_checkpoints(const RunConfig& config) {
  const std::string what = config.resume ? "--resume " + config.resume_source : "--checkpoint " + config.checkpoint_path;
  if (const std::string why = simulation_unsupported(config); !why.empty())
    throw std::invalid_argument(what + ": the run must go through a Simulation, " + why);
  if (!config.record_path.empty())
    throw std::invalid_argument("--record cannot be combined with --checkpoint or --resume (a replay file holds a "
                                "run from step 0)");
  const std::int64_t first = config.resume ? config.resume->state.steps_done : 0;
  if (config.resume && config.steps < first)
    throw std::invalid_argument("--steps " + std::to_string(config.steps) + ": before step " + std::to_string(first) +
                                ", where checkpoint " + config.resume_source +
                                " was saved (with --resume, --steps is the scene step to reach, numbered as in the "
                                "run that saved it)");
  if (!config.checkpoint_path.empty() && (config.checkpoint_at < first || config.checkpoint_at > config.steps))
    throw std::invalid_argument("--checkpoint-at " + std::to_string(config.checkpoint_at) +
                                ": outside the run's steps " + std::to_string(first) + " .. " +
                                std::to_string(config.steps));
}

namespace {

void check_supported(const RunConfig& config) {
  const std::string what = !config.record_path.empty()     ? "--record"
                           : config.resume                  ? "--resume"
                           : !config.checkpoint_path.empty() ? "--checkpoint"
                                                             : "--inputs";
  if (config.world != WorldKind::Canonical)
    throw std::invalid_argument(what + " runs the canonical world only (not --world stock)");
  if (config.shuffle_seed != 0) throw std::invalid_argument(what + " cannot be combined with --shuffle-seed");
  if (config.resume || !config.checkpoint_path.empty()) check_checkpoints(config);
  if (config.record_path.empty()) return;
  if (const std::string why = simulation_unsupported(config); !why.empty())
    throw std::invalid_argument("--record " + config.record_path + ": the run must go through a Simulation, " + why);
}

// Reads every committed frame 0 .. steps through `reader` into the replay
// file while the worlds run (started up to `steps`); the last one carries
// the state hash. Frames hold the bodies alive at their step; the bodies
// the inputs add are described to the file (it stores a description before
// the first frame that holds the body). On the calling thread.
void record(Simulation& sim, SceneReader& reader, const Scene& scene, const TerritoryMap& map,
            const RunConfig& config, RunResult& r) {
  const std::int64_t cpu0 = thread_cpu_ns();
  const replay::ViewHeader header = view_header(scene, map);
  replay::ReplayWriter out(config.record_path, header,
                           {config.record_keyframe_every, config.record_compression_level});
  describe_added_bodies(out, config);
  sim.start(sim.time_of(config.steps));
  for (std::int64_t k = 0; k <= config.steps; ++k) {
    std::optional<SceneFrame> frame = reader.read_at(sim.time_of(k));
    if (!frame) throw std::logic_error("--record: the frame of step " + std::to_string(k) + " was not read");
    replay::ViewFrame v = view_frame(*frame, header, k == 0 ? &map : nullptr);
    if (k == config.steps) {
      sim.advance_to(sim.time_of(config.steps));
      v.state_hash = sim.state_hash();
    }
    out.append(v);
  }
  out.close();
  r.record_frames = out.frames();
  r.record_bytes = out.bytes();
  r.record_cpu_seconds = static_cast<double>(thread_cpu_ns() - cpu0) * 1e-9;
}

}  // namespace

void describe_added_bodies(replay::ReplayWriter& out, const RunConfig& config) {
  if (!config.inputs) return;
  for (const UserInput& in : *config.inputs)
    if (in.kind == UserInput::Kind::AddBody) out.describe(view_body(in.body));
}

SimulationConfig simulation_config(const RunConfig& config) {
  SimulationConfig sc;
  sc.territories = config.territories;
  sc.partition = config.partition;
  sc.threads = config.threads;
  sc.serialise = config.serialise;
  sc.runtime = config.runtime;  // a Simulation refuses load balancing and heal
  sc.grid = grid_options(config);
  // The worlds' reach has room for the largest body the inputs add.
  if (config.inputs)
    for (const UserInput& in : *config.inputs)
      if (in.kind == UserInput::Kind::AddBody)
        sc.runtime.added_extent = std::max(sc.runtime.added_extent, 2.0 * in.body.shape.bounding_radius());
  return sc;
}

namespace {
// What a Simulation does not run, other than the world kind: these send
// --inputs to the PartitionedWorld instead.
const char* feature_a_simulation_lacks(const RunConfig& config) {
  if (config.sync_test > 0) return "--sync-test";
  if (config.runtime.balance.policy != "none") return "load balancing (--lb): its map is fixed";
  if (config.runtime.watchdog.response == WatchdogResponse::Heal) return "--watchdog heal";
  return nullptr;
}
}  // namespace

void give_inputs(Simulation& sim, const std::vector<UserInput>& inputs, const std::string& source) {
  for (const UserInput& in : inputs) {
    try {
      sim.give(in);
    } catch (const std::invalid_argument& e) {
      throw SceneError(source + ": input #" + std::to_string(in.sequence) + " (" + input_kind_name(in.kind) +
                       " at step " + std::to_string(in.step) + "): " + e.what());
    }
  }
}

std::string simulation_unsupported(const RunConfig& config) {
  const char* what = config.world != WorldKind::Canonical ? "--world stock"
                     : config.shuffle_seed != 0            ? "--shuffle-seed"
                                                           : feature_a_simulation_lacks(config);
  return what ? std::string("which does not support ") + what : std::string();
}

// --world stock and --shuffle-seed stay on this path: check_supported
// refuses them there, naming --inputs.
bool inputs_through_simulation(const RunConfig& config) {
  return config.inputs_via_simulation && feature_a_simulation_lacks(config) == nullptr;
}

bool through_simulation_only(const RunConfig& config) {
  return !config.record_path.empty() || !config.checkpoint_path.empty() || config.resume != nullptr;
}

RunResult run_with_inputs(const Scene& scene, const RunConfig& config) {
  check_supported(config);
  SimulationConfig sc = simulation_config(config);
  // The worlds' reach has room for the largest body a resumed checkpoint's
  // queued inputs add (simulation_config makes room for config.inputs').
  if (config.resume)
    for (const UserInput& in : config.resume->inputs)
      if (in.kind == UserInput::Kind::AddBody)
        sc.runtime.added_extent = std::max(sc.runtime.added_extent, 2.0 * in.body.shape.bounding_radius());
  sc.buffer_capacity = std::max<std::size_t>(sc.buffer_capacity, static_cast<std::size_t>(config.runtime.anticipation) + 3);
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
      spdlog::info("{} {}: world 0 at step {}/{}, {:.1f} s elapsed", scene.name,
                   config.inputs                    ? "with inputs"
                   : !config.record_path.empty()   ? "recording"
                   : config.resume                 ? "resumed"
                                                   : "checkpointing",
                   step, config.steps,
                   static_cast<double>(now - t0) * 1e-9);
      next_progress = now + static_cast<std::int64_t>(config.progress_seconds * 1e9);
    }
  };
  // The map made here (as the Simulation would make it): a replay's header
  // and first frame name it.
  // A resumed run is cut around the bodies where the checkpoint has them
  // (the snapshot constructor's own partition); it records nothing.
  const std::optional<TerritoryMap> map =
      config.resume ? std::nullopt
                    : std::optional<TerritoryMap>(make_partition(config.partition, scene, config.territories, sc.grid));
  std::optional<Simulation> storage;
  if (config.resume) storage.emplace(*config.resume, sc);
  else storage.emplace(scene, *map, sc);
  Simulation& sim = *storage;
  std::optional<SceneReader> reader;
  if (!config.record_path.empty()) reader.emplace(sim.add_reader());
  if (config.inputs) give_inputs(sim, *config.inputs, config.inputs_source);
  RunResult r;
  r.world = WorldKind::Canonical;
  const std::int64_t first = config.resume ? config.resume->state.steps_done : 0;
  r.steps = static_cast<int>(config.steps - first);
  if (config.resume) r.resumed_at = first;
  r.territories = sim.world_count();
  r.partition = config.partition;
  r.schedule = schedule_name(sim.schedule());
  r.threads = sim.thread_count();
  r.anticipation = config.runtime.anticipation;
  r.rollback = config.runtime.rollback;
  t0 = wall_ns();
  next_progress = t0 + static_cast<std::int64_t>(config.progress_seconds * 1e9);
  if (reader) record(sim, *reader, scene, *map, config, r);
  if (!config.checkpoint_path.empty()) {
    sim.advance_to(sim.time_of(config.checkpoint_at));
    const SimulationSnapshot at = sim.snapshot();
    r.checkpoint_bytes = write_checkpoint(at, config.checkpoint_path);
    r.checkpoint_step = at.state.steps_done;
  }
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
