#include "soda/runtime/run.h"

#include <algorithm>
#include <chrono>
#include <memory>
#include <numeric>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <type_traits>

#include <sys/resource.h>

#include <BulletDynamics/Dynamics/btRigidBody.h>
#include <spdlog/spdlog.h>

#include "execution/plain_bytes.h"
#include "driver/rank_record.h"
#include "driver/run_inputs.h"
#include "soda/grid/partition.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/memory_estimate.h"
#include "soda/runtime/view_adapter.h"
#include "soda/scene/validate.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/solver_pool.h"
#include "soda/worlds/stock_world.h"

namespace soda {
namespace {

// RunConfig::sleeping = false. Bullet's process-wide "never sleep" switch,
// read by btRigidBody::wantsSleeping in every world kind; the one Bullet
// global SODA writes (docs/bullet-globals.md): set before the run's worlds
// exist, restored after they are gone, never while a world steps.
class SleepingSwitch {
 public:
  explicit SleepingSwitch(bool sleeping) : saved_(gDisableDeactivation) {
    if (!sleeping) gDisableDeactivation = true;
  }
  ~SleepingSwitch() { gDisableDeactivation = saved_; }
  SleepingSwitch(const SleepingSwitch&) = delete;
  SleepingSwitch& operator=(const SleepingSwitch&) = delete;

 private:
  bool saved_;
};

// RunResult::mean_height and bodies_below_ground from the final states.
void measure_pile(const std::vector<BodyState>& states, const Scene& scene, RunResult& r) {
  std::vector<BodyId> dynamic;
  for (const Body& b : scene.bodies)
    if (!b.is_static && !b.kinematic) dynamic.push_back(b.id);
  std::sort(dynamic.begin(), dynamic.end());
  double sum = 0;
  std::size_t above = 0;
  for (const BodyState& s : states) {
    if (!std::binary_search(dynamic.begin(), dynamic.end(), s.id)) continue;
    if (s.origin[1] < 0) {
      ++r.bodies_below_ground;
      continue;
    }
    sum += static_cast<double>(s.origin[1]);
    ++above;
  }
  if (above > 0) r.mean_height = sum / static_cast<double>(above);
}

// Steps `world` and measures it. W: StockWorld or CanonicalWorld (same
// step / state_hash / sleeping_count surface).
template <class W>
RunResult run_world(W& world, const Scene& scene, const RunConfig& config) {
  RunResult r;
  r.world = config.world;
  r.bodies = scene.bodies.size();
  r.dynamic_bodies = scene.dynamic_count();
  r.steps = config.steps;
  if constexpr (std::is_same_v<W, CanonicalWorld>) world.set_parking(config.runtime.parking);
  std::vector<std::int64_t> step_ns;
  step_ns.reserve(static_cast<std::size_t>(config.steps));
  const std::int64_t process_cpu0 = process_cpu_ns();
  const std::int64_t cpu0 = thread_cpu_ns();
  const std::int64_t t0 = wall_ns();
  std::int64_t next_progress = t0 + static_cast<std::int64_t>(config.progress_seconds * 1e9);
  for (int s = 0; s < config.steps; ++s) {
    const std::int64_t a = wall_ns();
    world.step();
    const std::int64_t b = wall_ns();
    if constexpr (std::is_same_v<W, CanonicalWorld>) {
      r.coloured_islands += world.last_step_stats().coloured_islands;
      r.substepped_islands += world.last_step_stats().substepped_islands;
      if (config.runtime.watchdog.response != WatchdogResponse::Off) {
        std::vector<WatchdogFinding> findings = world.watchdog_findings(config.runtime.watchdog.limits);
        if (!findings.empty()) throw WatchdogError(s + 1, kNoWorld, std::move(findings), config.runtime.watchdog.limits);
      }
    }
    step_ns.push_back(b - a);
    if (config.progress_seconds > 0 && b >= next_progress) {
      const double elapsed = static_cast<double>(b - t0) * 1e-9;
      const double eta = elapsed / (s + 1) * (config.steps - s - 1);
      spdlog::info("{} {}: step {}/{} ({:.0f} %), {:.1f} s elapsed, about {:.1f} s to go", scene.name,
                   world_kind_name(config.world), s + 1, config.steps, 100.0 * (s + 1) / config.steps,
                   elapsed, eta);
      next_progress = b + static_cast<std::int64_t>(config.progress_seconds * 1e9);
    }
  }
  r.wall_seconds = static_cast<double>(wall_ns() - t0) * 1e-9;
  r.cpu_seconds = static_cast<double>(thread_cpu_ns() - cpu0) * 1e-9;
  r.process_cpu_seconds = static_cast<double>(process_cpu_ns() - process_cpu0) * 1e-9;
  r.step_time = StepTimeStats::from_ns(std::move(step_ns));
  r.state_hash = world.state_hash();
  r.sleeping_bodies = world.sleeping_count();
  measure_pile(world.body_states(), scene, r);
  return r;
}

// Wall and calling-thread CPU clocks at one instant.
struct Stamp {
  std::int64_t wall = wall_ns(), cpu = thread_cpu_ns();
  double wall_since(const Stamp& a) const { return static_cast<double>(wall - a.wall) * 1e-9; }
  double cpu_since(const Stamp& a) const { return static_cast<double>(cpu - a.cpu) * 1e-9; }
};

// Builds a W, runs it, destroys it; times the building and the destruction.
template <class W, class... Args>
RunResult build_run_destroy(const Scene& scene, const RunConfig& config, const Stamp& start, Args&&... args) {
  auto world = std::make_unique<W>(std::forward<Args>(args)...);
  if constexpr (std::is_same_v<W, CanonicalWorld>) {
    if (config.runtime.solver_threads > 1) world->set_solver_pool(std::make_shared<SolverPool>(config.runtime.solver_threads));
    world->set_solver_defaults(config.solver_defaults);
  }
  const Stamp built;
  std::size_t bodies0 = 0, pairs0 = 0;
  if constexpr (std::is_same_v<W, CanonicalWorld>) {
    if (config.runtime.validate) bodies0 = world->body_count(), pairs0 = world->contact_state().size();
  }
  RunResult r = run_world(*world, scene, config);
  r.solver_threads = config.runtime.solver_threads;
  if constexpr (std::is_same_v<W, CanonicalWorld>) {
    if (config.runtime.validate) {
      r.bodies_at_start = bodies0;
      r.contact_pairs_at_start = pairs0;
      r.bodies_at_end = world->body_count();
      r.contact_pairs_at_end = world->contact_state().size();
    }
  }
  const Stamp stepped;
  world.reset();
  const Stamp gone;
  r.setup_seconds = built.wall_since(start);
  r.setup_cpu_seconds = built.cpu_since(start);
  r.teardown_seconds = gone.wall_since(stepped);
  r.teardown_cpu_seconds = gone.cpu_since(stepped);
  return r;
}

// Ranks: every rank's traffic and its worlds' CPU and blocked time, to rank
// 0, whose message counts become the whole run's.
void gather_rank_traffic(ProcessGroup& group, const PartitionedWorld& world, RunResult& r) {
  RankTraffic mine = group.traffic();
  mine.messages = world.messages_sent();
  mine.bytes = world.bytes_sent();
  mine.worlds = 0;
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  mine.peak_rss_bytes = static_cast<std::uint64_t>(usage.ru_maxrss) * 1024;  // Linux: kilobytes
  for (WorldId w = 0; w < world.world_count(); ++w) {
    mine.bullet_objects += world.world(w).bullet_object_count();
    if (group.rank_of(w, world.world_count()) != group.rank()) continue;
    ++mine.worlds;
    const WorldMetrics& m = r.world_metrics[static_cast<std::size_t>(w)];
    mine.blocked_seconds += m.blocked_seconds;
    mine.cpu_seconds += m.cpu_seconds;
  }
  std::vector<std::uint8_t> bytes;
  put_plain(bytes, mine);
  for (const std::vector<std::uint8_t>& part : group.gather(bytes)) {
    std::size_t at = 0;
    r.ranks.push_back(take_plain<RankTraffic>(part, at, "run_scene: a rank's traffic record"));
    if (at != part.size()) throw std::logic_error("run_scene: a rank's traffic record has extra bytes");
  }
  if (r.ranks.empty()) return;
  r.messages = r.message_bytes = 0;
  for (const RankTraffic& t : r.ranks) {
    r.messages += t.messages;
    r.message_bytes += t.bytes;
  }
}

// The PartitionedOptions of a partitioned run (its schedule and threads
// noted in `r`).
PartitionedOptions partitioned_options(const RunConfig& config, int k, RunResult& r) {
  PartitionedOptions options;
  if (config.threads == 1) {
    options.schedule = Schedule::Sequential;
    r.threads = 1;
  } else if (config.threads == 0 || config.threads >= k) {
    options.schedule = Schedule::ThreadPerWorld;
    r.threads = k;
  } else {
    options.schedule = Schedule::Pool;
    options.threads = config.threads;
    r.threads = config.threads;
  }
  r.schedule = schedule_name(options.schedule);
  options.serialise = config.serialise;
  options.runtime = config.runtime;
  options.sync_test = config.sync_test;
  if (config.inputs) options.inputs = *config.inputs;
  options.group = config.group;
  return options;
}

// What a partitioned run measured and ended with, into `r`.
void collect_partitioned(const PartitionedWorld& world, std::size_t scene_statics, const RunConfig& config,
                         RunResult& r) {
  r.world_metrics = world.metrics();
  for (const WorldMetrics& m : r.world_metrics) r.cpu_seconds += m.cpu_seconds;
  r.messages = world.messages_sent();
  r.reach_cells = world.world(0).map().reach();
  r.message_bytes = world.bytes_sent();
  if (config.group) gather_rank_traffic(*config.group, world, r);
  r.state_hash = world.state_hash();
  r.sleeping_bodies = world.sleeping_count();
  if (config.inputs) {  // at the end: the inputs added and removed bodies
    r.bodies = world.body_count();
    r.dynamic_bodies = r.bodies - scene_statics;
  }
  r.healed_steps = world.healed_steps();
  r.sync_rollbacks = world.sync_rollbacks();
  r.balance_log = world.balance_log();
  r.step_loads = world.step_loads();
  for (const WorldMetrics& m : r.world_metrics) r.migrations += m.migrations_out;
  for (const WorldMetrics& m : r.world_metrics) r.coloured_islands += m.coloured_islands;
  for (const WorldMetrics& m : r.world_metrics) r.guest_tasks += m.guest_tasks;
  for (const WorldMetrics& m : r.world_metrics) r.substepped_islands += m.substepped_islands;
}

// K > 1: all steps in one call (the worlds run without a barrier between
// steps); progress and step times come from world 0's thread. Every world
// inserts its bodies in the order of config.shuffle_seed. Inputs (when not
// through a Simulation: inputs_through_simulation) go to the PartitionedWorld.
RunResult run_partitioned(Scene scene, const RunConfig& config) {
  if (config.shuffle_seed != 0) scene = in_insertion_order(scene, config.shuffle_seed);
  if (config.world != WorldKind::Canonical)
    throw std::invalid_argument(config.territories > 1
                                    ? "--territories > 1 runs the canonical world only (not --world stock)"
                                    : "--watchdog heal, --sync-test, --lb and inputs run the canonical world only "
                                      "(not --world stock)");
  if (config.inputs && config.shuffle_seed != 0)
    throw std::invalid_argument("inputs cannot be combined with --shuffle-seed");
  RunResult r;
  r.world = config.world;
  r.bodies = scene.bodies.size();
  r.dynamic_bodies = scene.dynamic_count();
  const std::size_t scene_statics = r.bodies - r.dynamic_bodies;
  const std::string scene_name = scene.name;
  r.steps = config.steps;
  r.territories = config.territories;
  r.partition = config.partition;
  r.anticipation = config.runtime.anticipation;
  r.rollback = config.runtime.rollback;
  const TerritoryMap map = make_partition(config.partition, scene, config.territories, grid_options(config));
  const int k = map.world_count();
  PartitionedOptions options = partitioned_options(config, k, r);
  r.solver_threads = config.runtime.solver_threads;
  std::vector<std::int64_t> step_ends;  // written by world 0's thread only
  step_ends.reserve(static_cast<std::size_t>(config.steps));
  std::int64_t t0 = 0;
  std::int64_t next_progress = 0;
  options.progress = [&](std::int64_t done) {
    if (config.slow_world0_ms > 0)
      std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(config.slow_world0_ms));
    const std::int64_t now = wall_ns();
    step_ends.push_back(now);
    if (config.progress_seconds > 0 && now >= next_progress) {
      const double elapsed = static_cast<double>(now - t0) * 1e-9;
      const double eta = elapsed / static_cast<double>(done) * static_cast<double>(config.steps - done);
      spdlog::info("{} partitioned ({} worlds, {}): world 0 at step {}/{} ({:.0f} %), {:.1f} s elapsed, about "
                   "{:.1f} s to go",
                   scene_name, k, r.schedule, done, config.steps, 100.0 * static_cast<double>(done) / config.steps,
                   elapsed, eta);
      next_progress = now + static_cast<std::int64_t>(config.progress_seconds * 1e9);
    }
  };
  // --record over ranks: rank 0 writes the file (on threads a Simulation
  // records: run_with_inputs).
  std::optional<replay::ViewHeader> header;
  if (config.group && !config.record_path.empty() && config.group->rank() == 0) header = view_header(scene, map);
  const Stamp start;
  std::unique_ptr<PartitionedWorld> owned_world;
  const std::int64_t first = config.resume ? config.resume->state.steps_done : 0;
  try {
    if (config.resume) {  // over ranks (on threads a Simulation resumes): the state, its queued inputs first
      for (const UserInput& in : options.inputs)  // ids are never reused within a run
        if (in.kind == UserInput::Kind::AddBody &&
            std::binary_search(config.resume->retired_ids.begin(), config.resume->retired_ids.end(), in.body.id))
          throw SceneError(config.inputs_source + ": input #" + std::to_string(in.sequence) + " adds body " +
                           std::to_string(in.body.id) + ", removed before the step the checkpoint was saved at");
      options.inputs.insert(options.inputs.begin(), config.resume->inputs.begin(), config.resume->inputs.end());
      owned_world = std::make_unique<PartitionedWorld>(config.resume->state, map, options);
      r.resumed_at = first;
      r.steps = static_cast<int>(config.steps - first);
    } else {
      owned_world = std::make_unique<PartitionedWorld>(std::move(scene), map, options);
    }
  } catch (const std::invalid_argument& e) {
    // A bad input (PartitionedOptions::inputs): name where the inputs came from.
    if (config.inputs && std::string(e.what()).starts_with("PartitionedOptions::inputs"))
      throw SceneError(config.inputs_source + ": " + e.what());
    throw;
  }
  PartitionedWorld& world = *owned_world;
  const Stamp built;
  r.setup_seconds = built.wall_since(start);
  r.setup_cpu_seconds = built.cpu_since(start);
  if (config.runtime.validate) std::tie(r.bodies_at_start, r.contact_pairs_at_start) = census_counts(world, config);
  const std::int64_t process_cpu0 = process_cpu_ns();
  t0 = wall_ns();
  next_progress = t0 + static_cast<std::int64_t>(config.progress_seconds * 1e9);
  if (config.group && !config.record_path.empty())
    record_on_ranks(world, header ? &*header : nullptr, map, config, r);
  else if (config.group && !config.checkpoint_path.empty())
    checkpoint_on_ranks(world, options.inputs, config, r);
  else
    world.step(static_cast<int>(config.steps - first));
  r.wall_seconds = static_cast<double>(wall_ns() - t0) * 1e-9;
  r.process_cpu_seconds = static_cast<double>(process_cpu_ns() - process_cpu0) * 1e-9;
  std::vector<std::int64_t> step_ns;
  for (std::size_t i = 0; i < step_ends.size(); ++i) step_ns.push_back(step_ends[i] - (i ? step_ends[i - 1] : t0));
  r.step_time = StepTimeStats::from_ns(std::move(step_ns));
  collect_partitioned(world, scene_statics, config, r);
  if (config.runtime.validate) std::tie(r.bodies_at_end, r.contact_pairs_at_end) = census_counts(world, config);
  const Stamp stepped;
  owned_world.reset();
  const Stamp gone;
  r.teardown_seconds = gone.wall_since(stepped);
  r.teardown_cpu_seconds = gone.cpu_since(stepped);
  return r;
}

}  // namespace

const char* world_kind_name(WorldKind kind) {
  switch (kind) {
    case WorldKind::Canonical: return "canonical";
    case WorldKind::Stock: return "stock";
  }
  return "unknown";
}

const char* rollback_name(PartitionedOptions::Rollback rollback) {
  switch (rollback) {
    case PartitionedOptions::Rollback::Propagate: return "propagate";
    case PartitionedOptions::Rollback::Recompute: return "recompute";
  }
  return "unknown";
}

StepTimeStats StepTimeStats::from_ns(std::vector<std::int64_t> ns) {
  StepTimeStats s;
  if (ns.empty()) return s;
  std::sort(ns.begin(), ns.end());
  const auto ms = [](std::int64_t v) { return static_cast<double>(v) * 1e-6; };
  const double sum = std::accumulate(ns.begin(), ns.end(), 0.0);
  s.mean_ms = sum / static_cast<double>(ns.size()) * 1e-6;
  s.median_ms = ms(ns[ns.size() / 2]);
  s.p95_ms = ms(ns[std::min(ns.size() - 1, ns.size() * 95 / 100)]);
  s.max_ms = ms(ns.back());
  s.min_ms = ms(ns.front());
  return s;
}

namespace {

// run_scene for a scene it may take (S = Scene) or only read (const Scene&):
// a partitioned run over ranks frees what its rank does not hold.
template <class S>
RunResult run_any(S&& scene, const RunConfig& config) {
  if (config.steps < 0) throw std::invalid_argument("--steps must be >= 0");
  if (config.territories < 1) throw std::invalid_argument("--territories must be >= 1");
  if (config.threads < 0) throw std::invalid_argument("--threads must be >= 0");
  if (config.runtime.solver_threads < 1)
    throw std::invalid_argument("--solver-threads must be >= 1, got " + std::to_string(config.runtime.solver_threads));
  if (config.runtime.solver_threads > 1 && config.world == WorldKind::Stock)
    throw std::invalid_argument("--solver-threads > 1 runs the canonical world only (not --world stock)");
  if (config.sync_test < 0) throw std::invalid_argument("--sync-test must be >= 0");
  if (!(config.slow_world0_ms >= 0) || config.slow_world0_ms > 1000)
    throw std::invalid_argument("--slow-world0 must be in [0, 1000] ms");
  if (config.runtime.checkpoint_every < 1)
    throw std::invalid_argument("--checkpoint-every must be >= 1, got " + std::to_string(config.runtime.checkpoint_every));
  if (config.runtime.anticipation < 0)
    throw std::invalid_argument("--anticipation must be >= 0 (scene steps a world may run past the commit "
                                "horizon; 0: lockstep), got " + std::to_string(config.runtime.anticipation));
  if (config.runtime.anticipation > 0 && config.runtime.watchdog.response == WatchdogResponse::Heal)
    throw std::invalid_argument("--anticipation > 0 cannot be combined with --watchdog heal (speculation is not "
                                "supported with self-heal): use --watchdog stop or off, or --anticipation 0");
  make_balance_policy(config.runtime.balance);  // BalanceError (std::invalid_argument) for bad options
  if (config.solver_defaults != SolverDefaults::Soda &&
      (config.world != WorldKind::Canonical || config.territories > 1 || config.sync_test > 0 || config.inputs ||
       config.runtime.watchdog.response == WatchdogResponse::Heal || !config.record_path.empty() || config.group ||
       through_simulation_only(config)))
    throw std::invalid_argument("--solver-defaults bullet runs one canonical world only (not with --world stock, "
                                "--territories > 1, --sync-test, --watchdog heal, inputs, --record, checkpoints "
                                "or ranks)");
  const SleepingSwitch sleeping(config.sleeping);
  const Stamp start;
  const MemoryEstimate estimate = check_run_memory(scene, config);
  const auto with_estimate = [&](RunResult r) {
    r.memory_estimate_bytes = estimate.total();
    r.level_geometry_bytes = estimate.level_geometry_bytes;
    return r;
  };
  if (config.group) {
    if (config.world != WorldKind::Canonical) throw std::invalid_argument("over MPI ranks: the canonical world only");
    if (const std::string why = simulation_unsupported(config); !config.record_path.empty() && !why.empty())
      throw std::invalid_argument("--record " + config.record_path + ": over MPI ranks as on threads, a recorded "
                                  "run is one a Simulation runs, " + why);
    if (!config.checkpoint_path.empty() || config.resume) check_checkpoints(config);  // as on threads
    return with_estimate(run_partitioned(std::forward<S>(scene), config));
  }
  if (through_simulation_only(config) || (config.inputs && inputs_through_simulation(config)))
    return with_estimate(run_with_inputs(scene, config));
  if (config.territories > 1 || config.runtime.watchdog.response == WatchdogResponse::Heal || config.sync_test > 0 ||
      config.inputs)
    return with_estimate(run_partitioned(std::forward<S>(scene), config));
  const std::vector<std::size_t> order = insertion_order(scene.bodies.size(), config.shuffle_seed);
  switch (config.world) {
    case WorldKind::Stock: return with_estimate(build_run_destroy<StockWorld>(scene, config, start, scene, order));
    case WorldKind::Canonical: return with_estimate(build_run_destroy<CanonicalWorld>(scene, config, start, scene, order));
  }
  throw std::invalid_argument("unknown world kind");
}

}  // namespace

RunResult run_scene(const Scene& scene, const RunConfig& config) { return run_any(scene, config); }

RunResult run_scene(Scene&& scene, const RunConfig& config) { return run_any(std::move(scene), config); }

}  // namespace soda
