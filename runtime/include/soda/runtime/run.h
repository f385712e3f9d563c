// runtime/ — the step, threads, messages and the public API.
// This header: running a scene to completion and measuring it, the engine
// behind `soda run` and `soda bench`.
//
// territories = 1: one world, the canonical world or the stock Bullet world
// for comparison. territories = K > 1: the exact partitioned runtime
// (partitioned_world.h) on the canonical world, whose state hash equals the
// one-world run's.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/process_group.h"
#include "soda/runtime/simulation.h"
#include "soda/runtime/user_input.h"
#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"
#include "soda/worlds/canonical_world.h"

namespace soda {

/// Which Bullet world steps the scene.
enum class WorldKind {
  Canonical,  // order-independent, restorable (worlds/canonical_world.h)
  Stock,      // plain btDiscreteDynamicsWorld, the baseline
};
const char* world_kind_name(WorldKind kind);
/// "propagate" | "recompute", the names `--rollback` takes.
const char* rollback_name(PartitionedOptions::Rollback rollback);

struct RunConfig {
  WorldKind world = WorldKind::Canonical;
  int steps = 600;                   // steps to run
  int territories = 1;               // K; > 1: partitioned runtime (canonical world only)
  std::string partition = "kmeans";  // kmeans | rcb | grid:AxBxC | FILE
  std::optional<double> cell_size;   // the partition's cell edge, metres (unset: GridOptions' default)
  int threads = 0;                   // K > 1: 0 or >= K: one thread per world; 1: one thread
                                     // (round-robin); 2 .. K-1: a pool of that many threads
  bool serialise = false;            // K > 1: messages through bytes (as the tests do)
  /// The knobs every way of running a scene shares (runtime_options.h). With
  /// one territory: parking, solver_threads (the canonical world's pool),
  /// validate (bodies and contacts counted at the start and end) and the
  /// watchdog apply to the canonical world (neither to stock Bullet, the
  /// baseline, which refuses solver_threads > 1); the watchdog's Heal runs
  /// every territory count, 1 included, through the partitioned runtime;
  /// anticipation and reach have no neighbour to act on; load balancing is
  /// checked (BalanceError) but has nothing to balance. With inputs and load
  /// balancing the PartitionedWorld applies the inputs
  /// (inputs_via_simulation).
  RuntimeOptions runtime = {};
  /// 0: insert bodies in scene order; else every world (each territory's
  /// too) inserts its bodies in the order insertion_order gives.
  std::uint64_t shuffle_seed = 0;
  /// false: no body ever falls asleep, in any world of the run (Bullet's own
  /// switch, gDisableDeactivation, set for the length of the run and
  /// restored after: process-wide, so no other world of this process may
  /// step meanwhile; docs/bullet-globals.md). For benchmarks that compare
  /// worlds whose islands, hence sleepers, differ (`ratio_vs_baseline_awake`).
  bool sleeping = true;
  /// One territory, canonical world: the solver settings it steps with
  /// (CanonicalWorld::set_solver_defaults). Bullet: Bullet's own solver
  /// settings (`--solver-defaults bullet`), to measure what the defaults cost (`soda bench defaults`); refused
  /// with K > 1, the stock world and every path through the partitioned
  /// runtime (--sync-test, --watchdog heal, inputs, --record, ranks).
  SolverDefaults solver_defaults = SolverDefaults::Soda;
  double progress_seconds = 1.0;     // progress line period (<= 0: none)
  int sync_test = 0;                 // > 0: SyncTest (PartitionedOptions::sync_test); runs any K partitioned
  /// K > 1, experiments: world 0's thread sleeps this long after each of
  /// its steps (a slow world, as in the thesis' strip with world 0 slowed
  /// down). 0: none.
  double slow_world0_ms = 0;
  /// User inputs to replay (`soda run --inputs FILE` or a registry scene's
  /// own, scene_inputs; scene/input_file.h, docs/inputs.md). Given, the run
  /// goes through a Simulation making the embedding API's input calls with
  /// them in order, or through the PartitionedWorld's inputs
  /// (inputs_via_simulation), and ends on the hash the API gives, for every
  /// K. Not with the stock world or a shuffle seed.
  std::optional<std::vector<UserInput>> inputs;
  std::string inputs_source = "inputs";  // names the inputs in messages (the file)
  /// With inputs: true (the default) replays them through a Simulation
  /// unless the run balances load, runs SyncTest or heals (which a
  /// Simulation does not do: those give them to the PartitionedWorld,
  /// PartitionedOptions::inputs, with the same hash). false: always the
  /// PartitionedWorld (`soda lb`: every policy, "none" included, measured
  /// by the same runtime, with its per-step loads).
  bool inputs_via_simulation = true;
  /// Not empty: write a replay file there (docs/replay-format.md) of every
  /// committed frame, steps 0 .. steps, read through a SceneReader while
  /// the worlds run: the run goes through a Simulation (canonical world; not
  /// with load balancing, SyncTest, heal or a shuffle seed; bodies the
  /// inputs add and remove come and go in its frames). Over ranks (group)
  /// rank 0 writes the same frames from every step's poses gathered from
  /// the ranks (docs/mpi.md, "Recording"). The state hash is the same as
  /// without.
  std::string record_path;
  /// The replay's keyframe interval and zlib level (ReplayWriterOptions).
  int record_keyframe_every = 60;
  int record_compression_level = 1;
  /// Not empty: write a checkpoint file there (docs/checkpoints.md) of the
  /// run at scene step checkpoint_at (0 .. steps), then run on to `steps`:
  /// the run goes through a Simulation (`soda run --checkpoint-at STEP
  /// --checkpoint FILE`). The state hash is the same as without.
  std::string checkpoint_path;
  std::int64_t checkpoint_at = -1;
  /// Set: the run resumes this checkpoint (read_checkpoint; `soda run
  /// --resume FILE`) instead of starting the scene at step 0: run_scene's
  /// scene is scene_of(resume->state), and `steps` is the scene step to
  /// reach, numbered as in the run that saved it (>= the checkpoint's
  /// step). Through a Simulation, with any territories, partition, threads
  /// and anticipation; inputs, if given, are added to the checkpoint's own.
  std::shared_ptr<const SimulationSnapshot> resume;
  std::string resume_source = "checkpoint";  // names it in messages (the file)
  /// Ranks (MPI: docs/mpi.md; PartitionedOptions::group): the worlds are
  /// spread over the group's processes, every rank running run_scene with
  /// the same config; rank 0's result is the whole scene's (state hash,
  /// bodies, per-world metrics, `ranks`), the other ranks' hold their own
  /// worlds only. The canonical world only; not with the watchdog's
  /// heal (docs/mpi.md, "What is not done"). Null: one
  /// process.
  std::shared_ptr<ProcessGroup> group;
};

/// Summary statistics of per-step times, in milliseconds.
struct StepTimeStats {
  double mean_ms = 0, median_ms = 0, p95_ms = 0, max_ms = 0, min_ms = 0;
  static StepTimeStats from_ns(std::vector<std::int64_t> ns);
};

struct RunResult {
  std::uint64_t state_hash = 0;
  std::size_t bodies = 0;           // all bodies, statics included
  std::size_t dynamic_bodies = 0;
  std::size_t sleeping_bodies = 0;  // at the end of the run
  /// One territory (canonical or stock world): the mean height (centre y)
  /// at the end of the dynamic bodies whose centre is at or above y = 0 (the
  /// registry's ground top), and how many are below it (fallen off the
  /// ground's edge, left out of the mean): how tall a pile stands, so that
  /// "stable" is a number beside the time (`soda bench defaults`). NaN when
  /// none is above; unset (NaN, 0) for partitioned runs.
  double mean_height = std::numeric_limits<double>::quiet_NaN();
  std::size_t bodies_below_ground = 0;
  int steps = 0;
  int territories = 1;
  double wall_seconds = 0;          // stepping only, not scene set-up
  double cpu_seconds = 0;           // thread CPU time of the stepping thread(s)
  /// CPU time of the whole process while stepping: every thread (worlds,
  /// the solver pool's helpers, guests), so what two threads cost where
  /// cpu_seconds counts only the stepping thread(s). With MPI ranks: this
  /// rank's process.
  double process_cpu_seconds = 0;
  // Building the world(s) from the Scene (the memory check included) and
  // destroying them at the end, on the calling thread: wall seconds and that
  // thread's CPU seconds (docs/memory.md, "Setup and teardown").
  double setup_seconds = 0, setup_cpu_seconds = 0;
  double teardown_seconds = 0, teardown_cpu_seconds = 0;
  // The memory estimate the run was checked against before building
  // (memory_estimate.h, docs/memory.md): its total, and of it the shared
  // shapes of static meshes and heightfields, counted once per process.
  std::uint64_t memory_estimate_bytes = 0;
  std::uint64_t level_geometry_bytes = 0;
  // validate (canonical world): the whole scene's bodies and contact pairs
  // (manifolds holding points) counted from the worlds' own state after
  // building and at the end (docs/soak.md). 0 without validate.
  std::size_t bodies_at_start = 0, bodies_at_end = 0;
  std::size_t contact_pairs_at_start = 0, contact_pairs_at_end = 0;
  std::uint64_t migrations = 0;     // K > 1: bodies that changed owner (sum over worlds)
  StepTimeStats step_time;          // K > 1: intervals between world 0's step ends
  WorldKind world = WorldKind::Canonical;
  // Partitioned runs (territories > 1) only:
  std::string partition;            // the spec used
  std::string schedule;             // sequential | thread-per-world | pool
  int anticipation = 0;             // RuntimeOptions::anticipation
  int reach_cells = 1;              // cells the worlds' neighbourhoods reach (map_with_reach)
  PartitionedOptions::Rollback rollback = PartitionedOptions::Rollback::Propagate;
  int threads = 1;                  // threads that stepped the worlds
  std::uint64_t messages = 0;       // messages between worlds
  std::uint64_t message_bytes = 0;  // their bytes (0 unless serialised)
  std::vector<WorldMetrics> world_metrics;  // one per world, by id
  std::vector<std::int64_t> healed_steps;   // watchdog Heal: steps re-simulated with substeps
  std::uint64_t sync_rollbacks = 0;         // SyncTest: rollbacks checked bit-identical
  std::vector<BalanceRecord> balance_log;   // K > 1: PartitionedWorld::balance_log()
  std::vector<StepLoads> step_loads;        // K > 1 (not through a Simulation): PartitionedWorld::step_loads()
  // RunConfig::record_path: frames and bytes written, and the recording
  // thread's (the caller's) CPU time reading, quantising, compressing and
  // writing them.
  std::uint64_t record_frames = 0;
  std::uint64_t record_bytes = 0;
  double record_cpu_seconds = 0;
  /// RunConfig::checkpoint_path: its step and size; RunConfig::resume: the
  /// step it resumed at (-1: none).
  std::int64_t checkpoint_step = -1;
  std::uint64_t checkpoint_bytes = 0;
  std::int64_t resumed_at = -1;
  int solver_threads = 1;                   // RuntimeOptions::solver_threads
  std::uint64_t coloured_islands = 0;       // islands solved coloured, summed over steps (and worlds)
  std::uint64_t guest_tasks = 0;            // K > 1: WorldMetrics::guest_tasks summed over worlds
  std::uint64_t substepped_islands = 0;     // islands solved in substeps (docs/stress.md), summed over steps (and worlds)
  /// RunConfig::group, rank 0: every rank's traffic, by rank (else empty).
  std::vector<RankTraffic> ranks;
};

/// Insertion order of the scene's bodies for a shuffle seed (0: scene order).
/// Deterministic: a function of (body count, seed) only.
std::vector<std::size_t> insertion_order(std::size_t body_count, std::uint64_t shuffle_seed);

/// The grid of config's partition: its cell size, and no triangle weight
/// when the balance's triangle cost is off.
GridOptions grid_options(const RunConfig& config);

/// A copy of `scene` whose bodies are listed in insertion_order(bodies,
/// shuffle_seed): what the territory worlds of a shuffled run are built from.
Scene in_insertion_order(const Scene& scene, std::uint64_t shuffle_seed);

/// Runs `scene` for config.steps steps. Throws std::invalid_argument with a
/// clear message for an unsupported configuration (territories < 1,
/// territories > 1 or watchdog heal with the stock world, steps < 0,
/// anticipation < 0, anticipation > 0 with watchdog heal), GridError for a bad
/// partition, PartitionError when the scene leaves what the partitioned step
/// supports, MemoryLimitError (memory_estimate.h) before building anything
/// when the worlds cannot fit in the memory the process may have, and
/// std::bad_alloc when an allocation fails anyway. Blocks the calling thread; logs a progress line through spdlog
/// every config.progress_seconds.
RunResult run_scene(const Scene& scene, const RunConfig& config);
/// The same, taking the scene: a partitioned run builds its worlds from it
/// without a copy, and over ranks (config.group) each rank keeps only its
/// share and frees the rest before building (docs/mpi.md, "What a rank
/// holds"). The scene may be empty afterwards.
RunResult run_scene(Scene&& scene, const RunConfig& config);

/// The Simulation settings of a run: territories, partition, threads, pin,
/// serialise, validate, anticipation, solver_threads, rollback,
/// checkpoint_every, eager_bets, reach_speed, watchdog and balance copied
/// from `config`, added_extent the largest extent of a body config.inputs
/// add, the rest SimulationConfig's defaults. For the runs that go through
/// a Simulation (inputs, --record, --serve). Pure.
SimulationConfig simulation_config(const RunConfig& config);

/// Gives `inputs` to `sim` through its input calls, in order (add_body,
/// remove_body, set_velocity, apply_impulse at step * dt): what `soda run
/// --inputs` and `soda run --serve` do before the worlds start. Throws
/// SceneError naming `source`, the entry, its kind and step for an input the
/// Simulation refuses (unknown id, id in use, bad body, ...).
void give_inputs(Simulation& sim, const std::vector<UserInput>& inputs, const std::string& source);

/// Why `config` cannot run through a Simulation, naming the option it does
/// not support (--world stock, --shuffle-seed, --sync-test, --lb,
/// --watchdog heal); empty if it can. The one list behind the refusals of
/// --record and --serve, and behind which path --inputs takes. Pure.
std::string simulation_unsupported(const RunConfig& config);

}  // namespace soda
