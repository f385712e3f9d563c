// `soda bench defaults` (docs/stress.md "What the defaults cost"): one scene in one canonical world with the solver defaults
// (SolverDefaults::Soda) and with Bullet's own solver
// settings (SolverDefaults::Bullet), and in stock Bullet's own world (the
// baseline of every speed-up), interleaved (the order rotates every repeat)
// so that all see the same machine. Per configuration: every repeat's
// stepping-thread CPU and wall seconds, the least of each, the state hash,
// the pile's mean height at the end (RunResult::mean_height); the cost
// soda / bullet of the least CPU and wall seconds, and the speed-up
// stock / soda (> 1: the defaults are faster than stock Bullet).
// JSON on stdout (and --out FILE), a summary on stderr.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "soda/bench/result_json.h"
#include "soda/scene/registry.h"
#include "soda/scene/validate.h"
#include "soda/worlds/body_state.h"

namespace soda::cli {
namespace {

struct DefaultsOptions {
  std::string scene = "falling-cubes";
  SceneParams params;
  int steps = 600;
  int repeat = 3;
  std::string out;
  bool stock = true;
};

struct DefaultsRun {
  const char* name;
  SolverDefaults defaults;
  WorldKind world;
  std::vector<double> cpu{}, wall{};
  std::uint64_t hash = 0;
  std::size_t sleeping = 0;
  double mean_height = 0;
  std::size_t below_ground = 0;
  double least_cpu() const { return *std::min_element(cpu.begin(), cpu.end()); }
  double least_wall() const { return *std::min_element(wall.begin(), wall.end()); }
};

nlohmann::json run_json(const DefaultsRun& run) {
  return {{"defaults", run.name},
          {"world", world_kind_name(run.world)},
          {"state_hash", hash_hex(run.hash)},
          {"sleeping_bodies", run.sleeping},
          {"mean_height", run.mean_height},
          {"bodies_below_ground", run.below_ground},
          {"cpu_seconds", run.cpu},
          {"wall_seconds", run.wall},
          {"cpu_seconds_least", run.least_cpu()},
          {"wall_seconds_least", run.least_wall()}};
}

int run_defaults(DefaultsOptions& o) {
  Scene scene = make_scene(o.scene, o.params);
  scene.settings.steps = o.steps;
  validate_scene(scene, o.scene);
  RunConfig base;
  base.steps = o.steps;
  base.progress_seconds = 0;
  DefaultsRun soda_run{"soda", SolverDefaults::Soda, WorldKind::Canonical};
  DefaultsRun bullet_run{"bullet", SolverDefaults::Bullet, WorldKind::Canonical};
  DefaultsRun stock_run{"stock", SolverDefaults::Soda, WorldKind::Stock};
  std::vector<DefaultsRun*> runs = {&soda_run, &bullet_run};
  if (o.stock) runs.push_back(&stock_run);
  for (int r = 0; r < o.repeat; ++r) {
    for (std::size_t i = 0; i < runs.size(); ++i) {
      DefaultsRun* run = runs[(i + static_cast<std::size_t>(r)) % runs.size()];
      RunConfig c = base;
      c.world = run->world;
      if (run->world == WorldKind::Canonical) c.solver_defaults = run->defaults;
      const RunResult res = run_scene(scene, c);
      run->cpu.push_back(res.cpu_seconds);
      run->wall.push_back(res.wall_seconds);
      run->hash = res.state_hash;
      run->sleeping = res.sleeping_bodies;
      run->mean_height = res.mean_height;
      run->below_ground = res.bodies_below_ground;
      std::fprintf(stderr, "  repeat %d/%d %-6s cpu %.3f s wall %.3f s mean height %.3f m hash %s\n", r + 1,
                   o.repeat, run->name, res.cpu_seconds, res.wall_seconds, res.mean_height,
                   hash_hex(res.state_hash).c_str());
    }
  }
  const double cpu_cost = soda_run.least_cpu() / std::max(bullet_run.least_cpu(), 1e-12);
  const double wall_cost = soda_run.least_wall() / std::max(bullet_run.least_wall(), 1e-12);
  nlohmann::json j = {{"bench", "defaults"},
                      {"scene", o.scene},
                      {"n", o.params.n},
                      {"seed", o.params.seed},
                      {"bodies", scene.bodies.size()},
                      {"steps", o.steps},
                      {"repeat", o.repeat},
                      {"precision", kPrecisionName},
                      {"cpu_cost_vs_bullet", cpu_cost},
                      {"wall_cost_vs_bullet", wall_cost}};
  for (const DefaultsRun* run : runs) j["runs"].push_back(run_json(*run));
  std::fprintf(stderr, "defaults bench, %s n=%d, %d steps, least of %d: cost vs bullet (soda / bullet) CPU %.3f, wall %.3f\n",
               o.scene.c_str(), o.params.n, o.steps, o.repeat, cpu_cost, wall_cost);
  if (o.stock) {
    // One meaning everywhere: baseline time / our time, > 1 is faster.
    const double cpu_speedup = stock_run.least_cpu() / std::max(soda_run.least_cpu(), 1e-12);
    const double wall_speedup = stock_run.least_wall() / std::max(soda_run.least_wall(), 1e-12);
    j["speedup_vs_stock_cpu"] = cpu_speedup;
    j["speedup_vs_stock_wall"] = wall_speedup;
    std::fprintf(stderr, "  speed-up of the defaults over stock Bullet (stock / soda): CPU %.3f, wall %.3f; mean height soda %.3f m, bullet settings %.3f m, stock %.3f m\n",
                 cpu_speedup, wall_speedup, soda_run.mean_height, bullet_run.mean_height, stock_run.mean_height);
  }
  write_json(j, "-");
  if (!o.out.empty()) write_json(j, o.out);
  return 0;
}

}  // namespace

Command add_defaults_command(CLI::App& bench) {
  auto o = std::make_shared<DefaultsOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "defaults",
      "The cost of the solver defaults: one canonical world with them (soda) and with Bullet's own solver "
      "settings (bullet), interleaved; CPU and wall ratios; JSON on stdout");
  cmd->add_option("--scene", o->scene, "Registry scene name")->capture_default_str();
  cmd->add_option("--n", o->params.n, "Scene size (0: the scene's default)")
      ->check(CLI::Range(0, 1 << 24))
      ->capture_default_str();
  cmd->add_option("--seed", o->params.seed, "Seed of the scene generator")->capture_default_str();
  cmd->add_option("--steps", o->steps, "Steps of every run")->check(CLI::Range(1, 1 << 24))->capture_default_str();
  cmd->add_option("--repeat", o->repeat, "Interleaved repeats of each configuration (the least time counts)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Also write the JSON to this file");
  cmd->add_flag("!--no-stock", o->stock, "Leave out the run in stock Bullet's own world");
  return {cmd, [o] { return run_defaults(*o); }};
}

}  // namespace soda::cli
