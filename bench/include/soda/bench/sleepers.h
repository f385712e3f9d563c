// bench/ — `soda bench sleepers` (docs/skip.md): what a scene costs
// when most of it sleeps. The sleepers scene (docs/scenes.md) against the
// same scene without its sleepers (the active bodies alone, same ids), each
// on SODA (the configuration under test) and on stock Bullet, in one
// process, interleaved; the figure is cost_vs_active_only, the per-step
// time with the sleepers over the per-step time without (1: sleepers cost
// nothing; stock Bullet: 14–19 at 100,000 sleepers).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "soda/bench/bench.h"
#include "soda/bench/result_json.h"
#include "soda/rollback/transform_buffer.h"

namespace soda {

struct SleepersBenchConfig {
  /// The SODA runs' configuration (steps, territories, parking, ...);
  /// world is Canonical for them and Stock for the baselines.
  RunConfig run;
  int repeat = 1;  // interleaved repeats; the fastest (thread CPU) of each run is kept
  /// > 0: also measure the transform buffers' memory per buffered step
  /// (buffer_memory_run) with this capacity, from step `buffer_from`, for
  /// the full scene and the active bodies alone, delta entries on and off.
  std::size_t buffer_steps = 0;
  int buffer_from = 120;
};

/// What the transform buffers of a Simulation hold when full.
struct BufferMemoryRun {
  std::string name;  // full-delta | active-only-delta | full-no-delta | active-only-no-delta
  bool delta = true;
  std::size_t bodies = 0;           // dynamic bodies of the scene
  std::size_t sleeping_bodies = 0;  // at the last step
  int from = 0;                     // first held step
  BufferMemory memory;              // summed over the worlds
  /// Bytes each buffered step adds (the entries' own storage).
  std::size_t bytes_per_step() const { return memory.entries ? memory.delta_bytes / memory.entries : 0; }
  /// The same with the key entries shared out over the held entries.
  std::size_t bytes_per_step_with_keys() const { return memory.entries ? memory.total() / memory.entries : 0; }
};

/// One configuration and its repeats.
struct SleepersRun {
  std::string name;  // soda-full | soda-active-only | soda-near-only | stock-full | stock-active-only
  RunResult best;    // the repeat with the least thread CPU
  std::vector<double> cpu_seconds;  // every repeat
};

struct SleepersBenchResult {
  std::vector<SleepersRun> runs;  // in the order of `names`
  static constexpr const char* names[] = {"soda-full", "soda-active-only", "soda-near-only", "stock-full",
                                          "stock-active-only"};
  const SleepersRun& run(const std::string& name) const;
  /// Thread CPU per step of soda-full over soda-active-only (the figure).
  double cost_vs_active_only = 0;
  double cost_vs_active_only_wall = 0;  // the same with wall seconds
  double stock_cost_vs_active_only = 0;  // stock-full over stock-active-only, thread CPU
  double stock_cost_vs_active_only_wall = 0;
  /// soda-full over soda-near-only (the scene without the sleepers far from
  /// the active bodies, near_sleepers): what the far sleepers cost, the
  /// activity being the same; and soda-near-only over soda-active-only:
  /// what landing on sleepers instead of the ground costs (physics).
  double cost_vs_near_only = 0;
  double near_cost_vs_active_only = 0;
  /// True if soda-near-only ended with as many bodies awake as soda-full
  /// (a check that the far sleepers were never touched).
  bool near_same_awake = false;
  std::vector<BufferMemoryRun> buffer_runs;  // with buffer_steps > 0
};

/// The scene without its sleepers (bodies with Body::asleep): the active
/// bodies and the statics, same ids and settings.
Scene without_sleepers(const Scene& scene);

/// The scene without its sleepers farther than `margin` metres (in x or z)
/// from the box around its active bodies' start positions.
Scene near_sleepers(const Scene& scene, double margin);
/// Runs the five configurations `config.repeat` times, in order on even
/// repeats and in reverse order on odd ones. Throws what run_scene throws;
/// repeat < 1 is std::invalid_argument.
SleepersBenchResult bench_sleepers(const Scene& scene, const SleepersBenchConfig& config);

/// Runs `scene` under a Simulation of `territories` worlds (transform
/// buffers of `capacity` entries, delta entries on or off) to step `from`,
/// reads it, then runs capacity - 1 steps more with the reader left there:
/// every buffer then holds `capacity` entries, which are measured.
BufferMemoryRun buffer_memory_run(const Scene& scene, int territories, int from, std::size_t capacity, bool delta);
nlohmann::json buffer_memory_json(const std::vector<BufferMemoryRun>& runs);

/// The benchmark's JSON document (docs/skip.md).
nlohmann::json sleepers_bench_json(const RunDescription& d, const SleepersBenchConfig& config,
                                   const SleepersBenchResult& r);

}  // namespace soda
