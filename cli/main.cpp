// soda — run, benchmark and inspect SODA scenes. See docs/cli.md.
//
// Exit codes: 0 success; 1 the run failed; 2 bad input (usage, scene,
// partition or configuration errors); 3 out of memory (the run cannot fit,
// or an allocation failed: docs/memory.md), always with a message on stderr.
#include <cstdio>
#include <exception>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.h"
#include "partition_png.h"
#include "soda/bench/bench.h"
#include "soda/bench/result_json.h"
#include "soda/grid/partition.h"
#include "soda/replay/replay_error.h"
#include "soda/runtime/checkpoint.h"
#include "soda/scene/input_file.h"
#include "soda/runtime/memory_estimate.h"
#include "soda/scene/registry.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"
#include "soda/worlds/body_state.h"
#ifdef SODA_HAVE_MPI
#include "soda/mpi/mpi_group.h"
#include "soda/mpi/mpi_session.h"
#endif

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;
// The envelope the worlds of this build need (docs/scene-format.md).
constexpr soda::Precision kPrecision = soda::kDoublePrecision ? soda::Precision::Double : soda::Precision::Float;

// Seeds are unsigned 64-bit integers: CLI11 would wrap "-1" to 2^64 - 1.
const CLI::Validator kUnsigned(
    [](std::string& text) -> std::string {
      const std::size_t first = text.find_first_not_of(" \t");
      if (first != std::string::npos && text[first] == '-')
        return "must be >= 0 (an unsigned 64-bit integer), got " + text;
      return "";
    },
    "UINT64");
constexpr int kExitOutOfMemory = 3;

// Options shared by `run` and `bench`.
struct Options {
  std::string scene = "falling-cubes";
  soda::SceneParams params;
  std::optional<int> steps;
  std::optional<double> dt;
  std::optional<int> iterations;
  soda::RunConfig config;
  std::string world = "canonical";
  std::string watchdog = "stop";
  std::string solver_defaults = "soda";
  std::string rollback = "propagate";
  std::string json_path;
  std::string inputs_path;  // run: an input file to replay (docs/inputs.md)
  std::string resume_path;  // run: a checkpoint to resume (docs/checkpoints.md)
  int repeat = 3;
  bool no_awake = false;  // bench: skip the runs with sleeping off
  std::optional<int> serve_port;  // run --serve: the browser viewer, live (docs/viewer.md)
  double serve_linger = soda::cli::ServeOptions{}.linger_seconds;
  bool serve_wait = false;
  std::string ranks_worlds;  // run under mpirun: the rank of each world (docs/mpi.md)
};

void add_scene_options(CLI::App& cmd, Options& o) {
  cmd.add_option("--scene", o.scene, "Registry scene name or a .json scene file")->capture_default_str();
  cmd.add_option("--n", o.params.n, "Scene size: cubes for falling-cubes and cube-pile (default 1000), see docs/scenes.md; 0: the scene's default")
      ->capture_default_str();
  cmd.add_option("--seed", o.params.seed, "Seed of the scene generator (>= 0)")->check(kUnsigned)->capture_default_str();
  cmd.add_flag("--random-scale", o.params.random_scale, "falling-cubes: edges uniform in [0.2, 1.3] m");
}

void add_run_options(CLI::App& cmd, Options& o) {
  add_scene_options(cmd, o);
  cmd.add_option("--steps", o.steps, "Steps to run (default: the scene's, 600 for generated scenes)");
  cmd.add_option("--dt", o.dt, "Fixed step in seconds (default: the scene's, 1/60)");
  cmd.add_option("--iterations", o.iterations, "Solver iterations (default: the scene's, 10)");
  cmd.add_option("--territories", o.config.territories, "Number of territories (worlds)")->capture_default_str();
  cmd.add_option("--partition", o.config.partition, "kmeans | rcb | grid:AxBxC | territory-map file")
      ->capture_default_str();
  cmd.add_option("--cell-size", o.config.cell_size,
                 "Cell edge of the partition's grid in metres (default: the extent 90 % of the dynamic bodies fit "
                 "in); larger cells for scenes spread too wide for the default");
  cmd.add_option("--threads", o.config.threads,
                 "Threads stepping the worlds: 0 or >= territories: one per world; 1: all worlds round-robin on "
                 "one thread; in between: a pool")
      ->capture_default_str();
  cmd.add_flag("--validate", o.config.runtime.validate,
               "Check after every step: one owner per body, one holder per contact pair, Bullet object counts "
               "(territories > 1; slow; a violation stops the run naming step, bodies and worlds)");
  cmd.add_flag("--serialise", o.config.serialise,
               "Send every message between worlds through bytes, as a process boundary would (territories > 1)");
  cmd.add_flag("--pin", o.config.runtime.pin, "Pin world threads to cores (one thread per world)");
  cmd.add_option("--solver-threads", o.config.runtime.solver_threads,
                 "Threads that solve the colours of a large island (the stepping thread plus helpers shared by "
                 "all worlds; results are identical for every value; canonical world only); docs/coloured-solve.md")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd.add_option("--solver-guests", o.config.runtime.solver_guests,
                 "Territories > 1, one thread per world: how many world threads waiting for a message may take "
                 "tasks of another world's solve meanwhile (-1: the cores the run leaves free; 0: none; results "
                 "are identical for every value); docs/coloured-solve.md")
      ->check(CLI::Range(-1, 256))
      ->capture_default_str();
  cmd.add_option("--shuffle-seed", o.config.shuffle_seed,
                 "Every world (each territory's too) inserts its bodies in an order shuffled by this seed (0: "
                 "scene order); the canonical world's results do not depend on it")
        ->check(kUnsigned)
      ->capture_default_str();
  cmd.add_option("--world", o.world, "canonical | stock")->capture_default_str();
  cmd.add_option("--watchdog", o.watchdog,
                 "After every step check for NaN/Inf, absurd speeds and deep penetrations: off | stop (exit with "
                 "the step and bodies) | heal (roll back and re-simulate the bad step with substeps); "
                 "docs/watchdog.md")
      ->capture_default_str();
  cmd.add_option("--heal-substeps", o.config.runtime.watchdog.heal_substeps,
                 "--watchdog heal: substeps of a re-simulated step")
      ->capture_default_str();
  cmd.add_option("--solver-defaults", o.solver_defaults,
                 "soda (the defaults) | bullet (Bullet's own solver settings, one canonical world only: to "
                 "measure what the defaults cost); docs/stress.md")
      ->capture_default_str();
  cmd.add_flag("--no-parking{false}", o.config.runtime.parking,
               "Keep sleeping islands inside Bullet's world (the canonical world's, or every territory "
               "world's) instead of parking them outside it (same state hash; docs/skip.md)");
  cmd.add_flag("--no-idle-skip{false}", o.config.runtime.idle_territories,
               "K > 1: every world runs every stage of every step, idle territories too (same state hash; "
               "docs/skip.md)");
  cmd.add_option("--sync-test", o.config.sync_test,
                 "SyncTest: after every step roll every world back this many steps, re-run them and require "
                 "bit-identical state (0: off; costs that many extra steps per step)")
      ->capture_default_str();
  cmd.add_option("--anticipation", o.config.runtime.anticipation,
                 "Speculation: scene steps a world may run past the commit horizon, betting that its neighbours "
                 "send it nothing (0: lockstep; results are identical for every value; territories > 1; not with "
                 "--watchdog heal); docs/rollback.md")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  cmd.add_option("--reach-speed", o.config.runtime.reach_speed,
                 "Speed (m/s) the worlds' neighbourhoods are sized for: every world talks to the worlds owning a "
                 "cell its bodies' halos and migrations can reach at this speed (0: the scene's fastest initial "
                 "speed plus a fall through its height); a faster body stops the run naming it; "
                 "docs/partitioned-step.md")
      ->check(CLI::Range(0.0, 1e9))
      ->capture_default_str();
  cmd.add_option("--rollback", o.rollback,
                 "What a rollback makes the neighbours do (with --anticipation): propagate (re-run only where a "
                 "message they used changed) | recompute (every neighbour that used a rolled-back step re-runs "
                 "too; the baseline)")
      ->check(CLI::IsMember({"propagate", "recompute"}))
      ->capture_default_str();
  cmd.add_option("--checkpoint-every", o.config.runtime.checkpoint_every,
                 "Speculation: internal steps between the states a world keeps to roll back to (1: every step, "
                 "and re-run steps replay the islands that come out unchanged; a rollback restores the one at "
                 "or before the step and re-runs the rest)")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd.add_flag("--eager-bets", o.config.runtime.eager_bets,
               "Speculation: bet also on neighbours whose newest ghosts were not empty (more bets and rollbacks; "
               "by default a world waits for a busy border)");
  cmd.add_option("--lb", o.config.runtime.balance.policy,
                 "Load balancing by cell cession (territories > 1): none | diffusive | rcb | churn (random cells, "
                 "to exercise the machinery); results are identical under every policy; docs/loadbalance.md")
      ->capture_default_str();
  soda::cli::add_balance_options(cmd, o.config.runtime.balance);
  cmd.add_option("--json", o.json_path, "Write results as JSON to this path ('-': stdout)");
}

void resolve_run_config(Options& o);

soda::Scene resolve_scene(Options& o) {
  soda::Scene scene = soda::load_or_make_scene(o.scene, o.params);
  if (o.dt) scene.settings.dt = *o.dt;
  if (o.iterations) scene.settings.iterations = *o.iterations;
  if (o.steps) scene.settings.steps = *o.steps;
  // Overrides must be valid too, and the scene must lie inside this build's
  // precision envelope (a file or generator is checked against the widest).
  std::string source = o.scene;
  if (o.dt) {
    char dt[32];
    std::snprintf(dt, sizeof dt, "%.17g", *o.dt);
    source += std::string(" with --dt ") + dt;
  }
  soda::validate_scene(scene, source, kPrecision);
  o.config.steps = scene.settings.steps;
  resolve_run_config(o);
  return scene;
}

// The run options that do not describe the scene.
void resolve_run_config(Options& o) {
  if (o.world == "canonical") o.config.world = soda::WorldKind::Canonical;
  else if (o.world == "stock") o.config.world = soda::WorldKind::Stock;
  else throw std::invalid_argument("--world must be 'canonical' or 'stock', got '" + o.world + "'");
  o.config.runtime.watchdog.response = soda::parse_watchdog_response(o.watchdog);
  if (o.solver_defaults == "soda") o.config.solver_defaults = soda::SolverDefaults::Soda;
  else if (o.solver_defaults == "bullet") o.config.solver_defaults = soda::SolverDefaults::Bullet;
  else throw std::invalid_argument("--solver-defaults must be 'soda' or 'bullet', got '" + o.solver_defaults + "'");
  o.config.runtime.rollback = o.rollback == "recompute" ? soda::PartitionedOptions::Rollback::Recompute
                                                : soda::PartitionedOptions::Rollback::Propagate;
  if (o.config.runtime.watchdog.heal_substeps < 1) throw std::invalid_argument("--heal-substeps must be >= 1");
}

void print_summary(const soda::RunResult& r) {
  // K > 1: the territory worlds of the partitioned runtime, whatever --world says.
  const std::string worlds = r.territories > 1 ? std::to_string(r.territories) + " territory worlds"
                                               : std::string(soda::world_kind_name(r.world)) + " world";
  std::printf("%s (%s): %zu bodies, %d steps in %.3f s (%.1f steps/s), state_hash %s, %zu asleep\n",
              worlds.c_str(), soda::kPrecisionName, r.bodies, r.steps, r.wall_seconds,
              r.wall_seconds > 0 ? r.steps / r.wall_seconds : 0.0, soda::hash_hex(r.state_hash).c_str(),
              r.sleeping_bodies);
  std::printf("  setup %.3f s (CPU %.3f s), teardown %.3f s (CPU %.3f s): %.2f us per body\n", r.setup_seconds,
              r.setup_cpu_seconds, r.teardown_seconds, r.teardown_cpu_seconds,
              r.bodies ? (r.setup_cpu_seconds + r.teardown_cpu_seconds) * 1e6 / static_cast<double>(r.bodies) : 0.0);
  if (r.memory_estimate_bytes > 0)
    std::printf("  memory estimate %.1f MiB, of it %.1f MiB of mesh and heightfield shapes (once per process; "
                "docs/memory.md)\n",
                static_cast<double>(r.memory_estimate_bytes) / (1 << 20), static_cast<double>(r.level_geometry_bytes) / (1 << 20));
  if (r.bodies_at_start || r.bodies_at_end)
    std::printf("  validate: %zu bodies and %zu contact pairs after building, %zu bodies and %zu contact pairs at "
                "the end; %llu migrations\n",
                r.bodies_at_start, r.contact_pairs_at_start, r.bodies_at_end, r.contact_pairs_at_end,
                static_cast<unsigned long long>(r.migrations));
  if (r.territories > 1)
    std::printf("  %d territories (%s), %s on %d thread(s), %llu messages, per-world CPU %.3f s in all, "
                "slowest world per step summed %.3f s\n",
                r.territories, r.partition.c_str(), r.schedule.c_str(), r.threads,
                static_cast<unsigned long long>(r.messages), r.cpu_seconds,
                soda::slowest_world_cpu_seconds(r.world_metrics));
  if (r.coloured_islands > 0 || r.solver_threads > 1)
    std::printf("  coloured solve: %llu islands solved coloured, on up to %d solver thread(s); %llu tasks taken by "
                "waiting world threads\n",
                static_cast<unsigned long long>(r.coloured_islands), r.solver_threads,
                static_cast<unsigned long long>(r.guest_tasks));
  if (r.substepped_islands > 0)
    std::printf("  substeps per island: %llu islands solved in substeps\n",
                static_cast<unsigned long long>(r.substepped_islands));
  if (r.territories > 1) {
    // Per stage, summed over the worlds: CPU seconds / seconds waited.
    const soda::WorldMetrics t = soda::total_metrics(r.world_metrics);
    std::printf("  by stage (CPU s / waited s):");
    for (std::size_t i = 0; i < soda::kStageCount; ++i) {
      const soda::StageCost& c = t.stages[i];
      if (c.cpu_seconds > 0 || c.wait_seconds > 0)
        std::printf(" %s %.3f/%.3f", soda::stage_name(static_cast<soda::Stage>(i)), c.cpu_seconds, c.wait_seconds);
    }
    std::printf("\n");
  }
  if (r.territories > 1 && r.anticipation > 0) {
    const soda::WorldMetrics sp = soda::total_metrics(r.world_metrics);
    std::printf("  speculation (anticipation %d, %s): %llu bets, %llu lost, %llu rollbacks, %llu steps rolled "
                "back (%llu rejoined), %llu bodies re-solved (%llu replayed), %.3f s rollback CPU, lead max %lld mean "
                "%.2f steps\n",
                r.anticipation, soda::rollback_name(r.rollback), static_cast<unsigned long long>(sp.bets),
                static_cast<unsigned long long>(sp.bets_lost), static_cast<unsigned long long>(sp.rollbacks),
                static_cast<unsigned long long>(sp.steps_rolled_back),
                static_cast<unsigned long long>(sp.steps_rejoined),
                static_cast<unsigned long long>(sp.bodies_resolved),
                static_cast<unsigned long long>(sp.bodies_replayed), sp.rollback_cpu_seconds,
                static_cast<long long>(sp.lead_max), sp.lead_mean);
  }
  if (!r.balance_log.empty()) {
    const soda::BalanceTotals t = soda::balance_totals(r.balance_log);
    std::printf("  load balancing: %lld balance steps, %lld cells and %lld bodies moved, %.4f s CPU (deciding "
                "%.4f s, applying %.4f s)\n",
                static_cast<long long>(t.balance_steps), static_cast<long long>(t.cells_moved),
                static_cast<long long>(t.bodies_moved), t.cpu_seconds(), t.gather_cpu_seconds + t.decide_cpu_seconds,
                t.apply_cpu_seconds);
  }
  for (const soda::RankTraffic& t : r.ranks)
    std::printf("  rank %d: %d world(s), CPU %.3f s, worlds blocked %.3f s; to other ranks %llu messages %llu bytes, "
                "from them %llu messages %llu bytes; communication loop %.3f s (%.3f s idle, %llu GVT rounds); "
                "%llu Bullet objects, peak RSS %.1f MB\n",
                t.rank, t.worlds, t.cpu_seconds, t.blocked_seconds, static_cast<unsigned long long>(t.messages_out),
                static_cast<unsigned long long>(t.bytes_out), static_cast<unsigned long long>(t.messages_in),
                static_cast<unsigned long long>(t.bytes_in), t.pump_seconds, t.pump_idle_seconds,
                static_cast<unsigned long long>(t.gvt_rounds),
                static_cast<unsigned long long>(t.bullet_objects), static_cast<double>(t.peak_rss_bytes) * 1e-6);
  if (r.sync_rollbacks)
    std::printf("  SyncTest: %llu rollbacks re-run bit-identical\n", static_cast<unsigned long long>(r.sync_rollbacks));
  for (std::int64_t step : r.healed_steps)
    std::printf("  watchdog: step %lld was bad; rolled back and re-simulated with substeps\n",
                static_cast<long long>(step));
}

void print_checkpoints(const Options& o, const soda::RunResult& r) {
  if (r.resumed_at >= 0)
    std::printf("  resumed %s at step %lld, ran to step %lld\n", o.resume_path.c_str(),
                static_cast<long long>(r.resumed_at), static_cast<long long>(o.config.steps));
  if (r.checkpoint_step >= 0)
    std::printf("  checkpoint at step %lld: %llu bytes to %s\n", static_cast<long long>(r.checkpoint_step),
                static_cast<unsigned long long>(r.checkpoint_bytes), o.config.checkpoint_path.c_str());
}

// soda run --resume FILE: the scene, its state and its queued inputs come
// from the checkpoint; --steps is the scene step to reach.
int cmd_resume(Options& o) {
  if (o.serve_port) throw std::invalid_argument("--serve cannot be combined with --resume");
  auto snapshot = std::make_shared<const soda::SimulationSnapshot>(soda::read_checkpoint(o.resume_path));
  soda::Scene scene = soda::scene_of(snapshot->state);
  scene.name = o.resume_path;
  o.scene = o.resume_path;
  resolve_run_config(o);
  o.config.steps = o.steps ? *o.steps : scene.settings.steps;
  o.config.resume = snapshot;
  o.config.resume_source = o.resume_path;
  if (!o.inputs_path.empty()) {
    o.config.inputs = soda::load_input_file(o.inputs_path);
    o.config.inputs_source = o.inputs_path;
  }
  const soda::RunResult r = soda::run_scene(scene, o.config);
  if (o.config.group && o.config.group->rank() != 0) return 0;  // rank 0 prints the whole scene's result
  print_summary(r);
  print_checkpoints(o, r);
  if (!o.json_path.empty())
    soda::write_json(soda::run_json({o.scene, o.params, &scene, o.config}, r), o.json_path);
  return 0;
}

int cmd_run(Options& o) {
  if (!o.resume_path.empty()) return cmd_resume(o);
  soda::Scene scene = resolve_scene(o);
  // A registry scene's own inputs (rain's later waves) are part of the
  // scene; an input file on top of them is refused rather than merged (the
  // two lists' ids and orders are nobody's to reconcile; write the scene's
  // with inputs_to_json and edit that file instead).
  std::vector<soda::UserInput> own = soda::scene_inputs(o.scene, o.params);
  if (!o.inputs_path.empty()) {
    if (!own.empty())
      throw std::invalid_argument("--inputs " + o.inputs_path + ": scene '" + o.scene + "' has " +
                                  std::to_string(own.size()) +
                                  " inputs of its own (docs/scenes.md), applied by themselves; an input file "
                                  "cannot be added to them (write them out with inputs_to_json, edit that file and "
                                  "run the scene without them, or use a scene without inputs)");
    o.config.inputs = soda::load_input_file(o.inputs_path);
    o.config.inputs_source = o.inputs_path;
  } else if (!own.empty()) {
    o.config.inputs = std::move(own);
    o.config.inputs_source = "scene '" + o.scene + "' (its inputs)";
  }
  if (o.serve_port && o.config.group)
    throw std::invalid_argument("--serve is not supported under mpirun yet (docs/mpi.md)");
  if (o.serve_port && !o.config.checkpoint_path.empty())
    throw std::invalid_argument("--serve cannot be combined with --checkpoint");
  if (o.serve_port) return soda::cli::serve_run(scene, o.config, {*o.serve_port, o.serve_linger, o.serve_wait});
  soda::Scene about;  // what the JSON row reads of the scene (its settings): run_scene takes the scene
  about.name = scene.name;
  about.settings = scene.settings;
  const soda::RunResult r = soda::run_scene(std::move(scene), o.config);
  if (o.config.group && o.config.group->rank() != 0) return 0;  // rank 0 prints the whole scene's result
  print_summary(r);
  print_checkpoints(o, r);
  if (!o.config.record_path.empty())
    std::printf("  recorded %llu frames, %llu bytes to %s (recording thread CPU %.3f s)\n",
                static_cast<unsigned long long>(r.record_frames), static_cast<unsigned long long>(r.record_bytes),
                o.config.record_path.c_str(), r.record_cpu_seconds);
  if (!o.json_path.empty())
    soda::write_json(soda::run_json({o.scene, o.params, &about, o.config}, r), o.json_path);
  return 0;
}

int cmd_bench(Options& o) {
  const soda::Scene scene = resolve_scene(o);
  soda::BenchConfig bc{o.config, o.repeat, !o.no_awake};
  const soda::BenchResult b = soda::bench_scene(scene, bc);
  if (o.config.group && o.config.group->rank() != 0) return 0;  // rank 0 prints and judges the whole scene's
  print_summary(b.run);
  std::printf("\n%s, %zu dynamic bodies, %d steps, %s; wall seconds of stepping, min of %d interleaved repeats\n",
              o.scene.c_str(), b.run.dynamic_bodies, b.run.steps, soda::kPrecisionName, o.repeat);
  std::fputs(soda::bench_table(b).c_str(), stdout);
  if (b.run.territories > 1) {
    const double slowest = soda::slowest_world_cpu_seconds(b.run.world_metrics);
    std::printf("projection (not measured): speed-up with one core per world %.3f (one-territory CPU / slowest "
                "world's CPU per step, summed)\n",
                slowest > 0 ? b.one_territory.cpu_seconds / slowest : 0.0);
  }
  std::fflush(stdout);
  if (!o.json_path.empty())
    soda::write_json(soda::bench_json({o.scene, o.params, &scene, o.config}, b), o.json_path);
  if (soda::bench_exit_code(b) == 0) return 0;
  std::fprintf(stderr, "soda: failed: the %d-territory state hash differs from the one-territory run's "
                       "(state_hash_equals_one_territory false): a decomposition bug\n",
               b.run.territories);
  return kExitFailure;
}

int cmd_export(Options& o, const std::string& out) {
  const soda::Scene scene = soda::load_or_make_scene(o.scene, o.params);
  soda::write_scene_file(scene, out);
  std::printf("wrote %s: %zu bodies (%zu dynamic)\n", out.c_str(), scene.bodies.size(), scene.dynamic_count());
  return 0;
}

// Shows how a scene would be cut: bodies and cells per territory, balance,
// neighbours. JSON with --json.
int cmd_partition(Options& o, std::optional<double> cell_size, double triangle_weight, const std::string& png_path) {
  const soda::Scene scene = soda::load_or_make_scene(o.scene, o.params);
  soda::GridOptions grid;
  grid.cell_size = cell_size;
  grid.triangle_weight = triangle_weight;
  const soda::TerritoryMap map = soda::make_partition(o.config.partition, scene, o.config.territories, grid);
  // The balance is shown with the documented weight whatever the partition
  // was made with, so that maps made with and without it compare.
  const soda::PartitionStats stats = soda::partition_stats(map, scene, soda::kTriangleWeight);
  nlohmann::json j = {{"scene", o.scene},
                      {"partition", o.config.partition},
                      {"territories", map.world_count()},
                      {"cell_size", map.grid().cell_size()},
                      {"triangle_weight", triangle_weight},
                      {"imbalance", stats.imbalance},
                      {"weighted_imbalance", stats.weighted_imbalance}};
  std::printf("%s: %d territories (%s, triangle weight %g), cell size %.3f m, imbalance %.3f (max/mean bodies), "
              "%.3f (max/mean weight at triangle weight %g)\n",
              o.scene.c_str(), map.world_count(), o.config.partition.c_str(), triangle_weight,
              map.grid().cell_size(), stats.imbalance, stats.weighted_imbalance, soda::kTriangleWeight);
  for (soda::WorldId w = 0; w < map.world_count(); ++w) {
    const auto neighbours = map.neighbours(w);
    const auto i = static_cast<std::size_t>(w);
    std::string ns;
    for (soda::WorldId n : neighbours) ns.append(ns.empty() ? "" : ",").append(std::to_string(n));
    std::printf("  world %2d: %6lld bodies %6lld cells %9lld body triangles %9.1f weight, neighbours [%s]\n", w,
                static_cast<long long>(stats.bodies_per_world[i]), static_cast<long long>(stats.cells_per_world[i]),
                static_cast<long long>(stats.body_triangles_per_world[i]), stats.weight_per_world[i], ns.c_str());
    j["worlds"].push_back({{"world", w},
                           {"bodies", stats.bodies_per_world[i]},
                           {"cells", stats.cells_per_world[i]},
                           {"body_triangles", stats.body_triangles_per_world[i]},
                           {"weight", stats.weight_per_world[i]},
                           {"neighbours", neighbours}});
  }
  if (!o.json_path.empty()) soda::write_json(j, o.json_path);
  if (!png_path.empty()) {
    const int layer = soda::cli::write_partition_png(png_path, map, scene);
    std::printf("  wrote %s: the map from above at cell layer y = %d (the one holding most bodies)\n",
                png_path.c_str(), layer);
  }
  return 0;
}

int cmd_scenes() {
  for (const soda::SceneGenerator& g : soda::scene_registry())
    std::printf("%-16s %s\n", g.name.c_str(), g.description.c_str());
  return 0;
}

}  // namespace

namespace soda::cli {

void add_balance_options(CLI::App& cmd, BalanceOptions& balance) {
  cmd.add_option("--lb-period", balance.period,
                 "Scene steps between balance steps (every world stops there while cells change owner; >= 1)")
      ->check(CLI::Range(1, 1 << 30))
      ->capture_default_str();
  cmd.add_option("--lb-seed", balance.seed, "Seed of the policy's tie-breaks and of churn's draws (>= 0)")
      ->check(kUnsigned)
      ->capture_default_str();
  cmd.add_option("--lb-smoothing", balance.smoothing,
                 "Weight of the newest period in the smoothed load, in (0, 1] (1: no history)")
      ->capture_default_str();
  cmd.add_option("--lb-overload", balance.overload,
                 "A world is overloaded above this x the mean smoothed busy time (> 1)")
      ->capture_default_str();
  cmd.add_option("--lb-underload", balance.underload,
                 "A world is underloaded below this x the mean smoothed busy time (in (0, 1))")
      ->capture_default_str();
  cmd.add_option("--lb-max-cells", balance.max_cells_per_move,
                 "Most cells one world gives away at one balance step (>= 1)")
      ->check(CLI::Range(1, 1 << 30))
      ->capture_default_str();
  cmd.add_flag("--no-triangle-cost{false}", balance.triangle_cost,
               "The first partition (kmeans, rcb) and the balance's cost model weigh bodies and contact pairs only, "
               "not the triangles of static meshes and heightfields within reach of their cells (same state hash; "
               "docs/loadbalance.md, \"Triangles\")");
}

}  // namespace soda::cli

namespace {

int soda_main(int argc, char** argv, [[maybe_unused]] bool under_mpi) {
  CLI::App app{"soda: one rigid-body scene, many Bullet worlds (" + std::string(soda::kPrecisionName) +
               " precision build)"};
  app.require_subcommand(1);
  app.fallthrough();  // global options (--log-level) may follow the subcommand
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error | off")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));

  Options run_o, bench_o, export_o;
  CLI::App* run = app.add_subcommand("run", "Run a scene and report its state hash and timings");
  add_run_options(*run, run_o);
  run->add_option("--inputs", run_o.inputs_path,
                  "Replay user inputs (add/remove bodies, set velocities, impulses at scene steps) from this JSON "
                  "file (docs/inputs.md): the same calls as the embedding API, the same hash for every territory "
                  "count");
  run->add_option("--record", run_o.config.record_path,
                  "Write a replay file of every committed frame (docs/replay-format.md), read through a SceneReader "
                  "while the worlds run (under mpirun: rank 0 writes it from every rank's poses, docs/mpi.md); the "
                  "state hash is unchanged. Inspect it with 'soda replay-info FILE'");
  run->add_option("--record-keyframes", run_o.config.record_keyframe_every,
                  "--record: frames from one keyframe to the next")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  run->add_option("--record-level", run_o.config.record_compression_level,
                  "--record: zlib level, 1 (fastest) .. 9 (smallest)")
      ->check(CLI::Range(1, 9))
      ->capture_default_str();
  CLI::Option* checkpoint =
      run->add_option("--checkpoint", run_o.config.checkpoint_path,
                      "Write a checkpoint file of the run at scene step --checkpoint-at (docs/checkpoints.md), then "
                      "run on; 'soda run --resume FILE' goes on from it to the same hash");
  CLI::Option* checkpoint_at =
      run->add_option("--checkpoint-at", run_o.config.checkpoint_at, "--checkpoint: the scene step to save at")
          ->check(CLI::NonNegativeNumber);
  checkpoint->needs(checkpoint_at);
  checkpoint_at->needs(checkpoint);
  CLI::Option* resume = run->add_option(
      "--resume", run_o.resume_path,
      "Resume a checkpoint file (docs/checkpoints.md): its scene, state and queued inputs, with any --territories, "
      "--partition, --threads, --anticipation; --steps is then the scene step to reach, numbered as in the run "
      "that saved it (default: the scene's steps), and --inputs adds inputs at or after its step");
  for (const char* scene_option : {"--scene", "--n", "--seed", "--random-scale", "--dt", "--iterations",
                                   "--shuffle-seed", "--record", "--world", "--solver-defaults"})
    resume->excludes(run->get_option(scene_option));
  run->add_option("--serve", run_o.serve_port,
                  "Serve the run to the browser viewer on 127.0.0.1:PORT while it runs (0: any free port; "
                  "docs/viewer.md)")
      ->check(CLI::Range(0, 65535));
  run->add_option("--serve-linger", run_o.serve_linger,
                  "With --serve: seconds to go on serving after the run ends (< 0: until Ctrl-C)")
      ->capture_default_str();
  run->add_option("--ranks-worlds", run_o.ranks_worlds,
                  "Under mpirun: the rank that steps each world, by world id (e.g. 0,0,1,1 for 4 territories on 2 "
                  "ranks; default round-robin, world w on rank w mod ranks); docs/mpi.md");
  run->add_flag("--serve-wait", run_o.serve_wait,
                "With --serve: start stepping once a browser has opened the page and asked for a frame (to watch from step 0)");
  CLI::App* bench = app.add_subcommand("bench", "Run a scene and a stock Bullet baseline side by side");
  bench->add_option("scene", bench_o.scene, "Registry scene name or .json file (same as --scene)");
  add_run_options(*bench, bench_o);
  bench->add_option("--repeat", bench_o.repeat, "Interleaved repeats; the minimum of each side is kept")
      ->capture_default_str();
  bench->add_option("--ranks-worlds", bench_o.ranks_worlds,
                    "Under mpirun: the rank that steps each world of the tested run, by world id (as `soda run`'s); "
                    "the baseline and the one-territory run are rank 0's; docs/mpi.md");
  bench->add_flag("--no-awake", bench_o.no_awake,
                  "Skip the second set of runs with sleeping off in every world (ratio_vs_baseline_awake)");
  std::string export_path;
  CLI::App* exp = app.add_subcommand("export-scene", "Write a scene (generated or loaded) as a JSON scene file");
  add_scene_options(*exp, export_o);
  exp->add_option("-o,--output", export_path, "Output path")->required();
  CLI::App* scenes = app.add_subcommand("scenes", "List the registered scene generators");
  Options part_o;
  std::optional<double> cell_size;
  std::string partition_png;
  CLI::App* part = app.add_subcommand("partition", "Show how a scene is cut into territories");
  add_scene_options(*part, part_o);
  part->add_option("--territories", part_o.config.territories, "Number of territories")->capture_default_str();
  part->add_option("--partition", part_o.config.partition, "kmeans | rcb | grid:AxBxC | territory-map file")
      ->capture_default_str();
  part->add_option("--cell-size", cell_size, "Cell edge in metres (default: the extent 90 % of the dynamic bodies fit in; larger bodies span several cells)");
  double triangle_weight = soda::kTriangleWeight;
  part->add_option("--triangle-weight", triangle_weight,
                   "kmeans and rcb weigh each body by 1 + this x the triangles of static meshes and heightfields "
                   "within reach of its cell (0: bodies only; docs/loadbalance.md, \"Triangles\")")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  part->add_option("--json", part_o.json_path, "Write the partition summary as JSON ('-': stdout)");
  part->add_option("--png", partition_png,
                   "Write a picture of the map seen from above (the layer of cells holding most bodies; "
                   "world colours as the viewer's, bodies as dots)");
  std::vector<soda::cli::Command> more = soda::cli::add_accuracy_commands(*bench);  // bench accuracy|accuracy-trace|analytic
  more.push_back(soda::cli::add_speculation_command(*bench));
  more.push_back(soda::cli::add_sleepers_command(*bench));
  more.push_back(soda::cli::add_idle_command(*bench));
  more.push_back(soda::cli::add_queries_command(*bench));
  more.push_back(soda::cli::add_defaults_command(*bench));
  more.push_back(soda::cli::add_broadphase_command(*bench));
  more.push_back(soda::cli::add_stress_command(app));
  more.push_back(soda::cli::add_lb_command(app));
  more.push_back(soda::cli::add_replay_info_command(app));
  more.push_back(soda::cli::add_view_command(app));
  app.footer(soda::cli::kRatioMeaning);
  bench->footer(soda::cli::kRatioMeaning);
  for (CLI::App* sub : bench->get_subcommands({})) sub->footer(soda::cli::kRatioMeaning);
  for (const soda::cli::Command& c : more)
    if (c.app->get_name() == "lb") c.app->footer(soda::cli::kRatioMeaning);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitBadInput;
  }

  auto logger = spdlog::stderr_color_mt("soda");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(log_level));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  try {
#ifdef SODA_HAVE_MPI
    if (under_mpi) {
      if (!*run && !(*bench && bench->get_subcommands().empty()))  // not bench's own subcommands
        throw std::invalid_argument(
            "under mpirun only `soda run` and `soda bench` spread their worlds over the ranks (docs/mpi.md)");
      Options& o = *run ? run_o : bench_o;
      o.config.group =
          soda::make_mpi_group(o.ranks_worlds.empty() ? std::vector<int>{} : soda::parse_ranks_worlds(o.ranks_worlds));
    }
#endif
    for (const Options* o : {&run_o, &bench_o})
      if (!o->ranks_worlds.empty() && !o->config.group)
        throw std::invalid_argument("--ranks-worlds needs the run to be started by mpirun (docs/mpi.md)");
    for (const soda::cli::Command& c : more)
      if (*c.app) return c.run();  // before `bench`: these are its subcommands
    if (*run) return cmd_run(run_o);
    if (*bench) return cmd_bench(bench_o);
    if (*exp) return cmd_export(export_o, export_path);
    if (*scenes) return cmd_scenes();
    if (*part) return cmd_partition(part_o, cell_size, triangle_weight, partition_png);
  } catch (const soda::replay::ReplayFormatError& e) {  // a file that is not a readable replay: bad input
    std::fprintf(stderr, "soda: error: %s\n", e.what());
    return kExitBadInput;
  } catch (const soda::SceneError& e) {
    std::fprintf(stderr, "soda: error: %s\n", e.what());
    return kExitBadInput;
  } catch (const soda::CheckpointError& e) {  // unreadable, truncated, damaged, foreign; or not writable
    std::fprintf(stderr, "soda: error: %s\n", e.what());
    return kExitBadInput;
  } catch (const std::invalid_argument& e) {  // includes soda::GridError
    std::fprintf(stderr, "soda: error: %s\n", e.what());
    return kExitBadInput;
  } catch (const soda::MemoryLimitError& e) {
    std::fprintf(stderr, "soda: out of memory: %s\n", e.what());
    return kExitOutOfMemory;
  } catch (const std::bad_alloc&) {  // the message itself must not allocate
    std::fputs("soda: out of memory: an allocation failed (the scene, its worlds or their contacts do not fit in "
               "the memory this process may have: ulimit -v / -d, the machine's or the cgroup's memory; "
               "docs/memory.md)\n",
               stderr);
    return kExitOutOfMemory;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "soda: failed: %s\n", e.what());
    return kExitFailure;
  }
  return kExitBadInput;
}

}  // namespace

int main(int argc, char** argv) {
#ifdef SODA_HAVE_MPI
  // Started by mpirun: MPI for the whole process, finalised after the run
  // (docs/mpi.md). A plain `soda ...` never initialises MPI.
  std::optional<soda::MpiSession> mpi;
  if (soda::MpiSession::launched_by_mpirun()) {
    try {
      mpi.emplace(&argc, &argv);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "soda: failed: %s\n", e.what());
      return kExitFailure;
    }
  }
  return soda_main(argc, argv, mpi.has_value());
#else
  return soda_main(argc, argv, false);
#endif
}
