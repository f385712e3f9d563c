// `soda bench sleepers` (docs/skip.md): JSON on stdout (and --out
// FILE), a readable summary on stderr.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "soda/bench/sleepers.h"
#include "soda/scene/registry.h"
#include "soda/scene/validate.h"

namespace soda::cli {
namespace {

struct SleepersOptions {
  SceneParams params;
  int steps = 300;
  SleepersBenchConfig bench;
  std::string out;
};

int run_sleepers(SleepersOptions& o) {
  Scene scene = make_scene("sleepers", o.params);
  scene.settings.steps = o.steps;
  validate_scene(scene, "sleepers");
  o.bench.run.steps = o.steps;
  const SleepersBenchResult r = bench_sleepers(scene, o.bench);
  const nlohmann::json j = sleepers_bench_json({"sleepers", o.params, &scene, o.bench.run}, o.bench, r);
  std::fprintf(stderr, "sleepers bench: %zu sleepers, %zu active, %d steps, parking %s, least thread CPU of %d\n",
               j["sleepers"].get<std::size_t>(), j["active"].get<std::size_t>(), o.steps,
               o.bench.run.runtime.parking ? "on" : "off", o.bench.repeat);
  std::fprintf(stderr, "  %-18s %12s %12s %9s  %s\n", "run", "cpu_ms/step", "wall_ms/step", "asleep", "state_hash");
  for (const nlohmann::json& run : j["runs"])
    std::fprintf(stderr, "  %-18s %12.3f %12.3f %9zu  %s\n", run["name"].get<std::string>().c_str(),
                 run["cpu_ms_per_step"].get<double>(), run["wall_ms_per_step"].get<double>(),
                 run["sleeping_bodies"].get<std::size_t>(), run["state_hash"].get<std::string>().c_str());
  std::fprintf(stderr, "  cost_vs_active_only: soda %.2f (wall %.2f), stock Bullet %.2f (wall %.2f)\n",
               r.cost_vs_active_only, r.cost_vs_active_only_wall, r.stock_cost_vs_active_only,
               r.stock_cost_vs_active_only_wall);
  std::fprintf(stderr,
               "  cost_vs_near_only: %.2f (the far sleepers' cost; same bodies awake: %s); near over active only: "
               "%.2f (landing on sleepers)\n",
               r.cost_vs_near_only, r.near_same_awake ? "yes" : "NO", r.near_cost_vs_active_only);
  for (const BufferMemoryRun& b : r.buffer_runs)
    std::fprintf(stderr, "  buffer %-22s %zu entries, %zu keys: %zu B per buffered step (%zu B with keys)\n",
                 b.name.c_str(), b.memory.entries, b.memory.key_entries, b.bytes_per_step(),
                 b.bytes_per_step_with_keys());
  write_json(j, "-");
  if (!o.out.empty()) write_json(j, o.out);
  return 0;
}

}  // namespace

Command add_sleepers_command(CLI::App& bench) {
  auto o = std::make_shared<SleepersOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "sleepers",
      "The sleepers scene against its active bodies alone, on SODA and on stock Bullet: cost_vs_active_only; JSON "
      "on stdout");
  cmd->add_option("--n", o->params.n, "Sleepers (0: 100,000); active bodies: ceil(n / 100)")
      ->check(CLI::Range(0, 1 << 26))
      ->capture_default_str();
  cmd->add_option("--seed", o->params.seed, "Seed of the scene generator")->capture_default_str();
  cmd->add_option("--steps", o->steps, "Steps of every run")->check(CLI::Range(1, 1 << 24))->capture_default_str();
  cmd->add_option("--territories", o->bench.run.territories, "Territories of the SODA runs")
      ->check(CLI::Range(1, 1 << 16))
      ->capture_default_str();
  cmd->add_flag("--no-parking{false}", o->bench.run.runtime.parking,
                "SODA keeps sleeping islands inside Bullet's world (the comparison without parking)");
  cmd->add_option("--repeat", o->bench.repeat, "Interleaved repeats; the least thread CPU of each run is kept")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--buffer-steps", o->bench.buffer_steps,
                  "Also measure the transform buffers' memory per buffered step with this many entries (0: no)")
      ->check(CLI::Range(0, 1 << 16))
      ->capture_default_str();
  cmd->add_option("--buffer-from", o->bench.buffer_from, "First step the buffer memory runs hold")
      ->check(CLI::Range(0, 1 << 24))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Also write the JSON to this file");
  return {cmd, [o] { return run_sleepers(*o); }};
}

}  // namespace soda::cli
