// `soda bench idle-territories` (docs/skip.md "Idle territories"): the
// idle-territories scene over eight territories (grid:8x1x1, a thread per
// world), idle skip on and off interleaved; per world, the thread CPU time
// per step (WorldMetrics::thread_cpu_seconds, the world's own thread), and
// `idle_over_busy`: the most an idle world (1..7) spent per step over what
// the busy one (world 0) spent. JSON on stdout (and --out FILE), a summary
// on stderr; exit 1 if the two runs' state hashes differ.
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

constexpr int kTerritories = 8;  // the scene's eight regions

struct IdleOptions {
  SceneParams params;
  int steps = 300;
  int repeat = 1;
  std::string out;
};

struct IdleRun {
  std::string name;
  RunResult result;  // the repeat with the least busy-world CPU
};

double cpu_ms_per_step(const WorldMetrics& m) {
  return m.steps > 0 ? 1e3 * m.thread_cpu_seconds / static_cast<double>(m.steps) : 0.0;
}

nlohmann::json run_json(const IdleRun& run) {
  nlohmann::json worlds = nlohmann::json::array();
  double idle_max = 0, idle_sum = 0;
  for (const WorldMetrics& m : run.result.world_metrics) {
    worlds.push_back({{"world", m.world},
                      {"thread_cpu_ms_per_step", cpu_ms_per_step(m)},
                      {"idle_steps", m.idle_steps},
                      {"steps", m.steps},
                      {"messages_sent", m.messages_sent}});
    if (m.world != 0) {
      idle_max = std::max(idle_max, cpu_ms_per_step(m));
      idle_sum += cpu_ms_per_step(m);
    }
  }
  const double busy = cpu_ms_per_step(run.result.world_metrics.at(0));
  const double idle_mean = idle_sum / (kTerritories - 1);
  return {{"name", run.name},
          {"state_hash", hash_hex(run.result.state_hash)},
          {"busy_cpu_ms_per_step", busy},
          {"idle_cpu_ms_per_step_max", idle_max},
          {"idle_cpu_ms_per_step_mean", idle_mean},
          {"idle_over_busy", busy > 0 ? idle_max / busy : 0.0},
          {"idle_mean_over_busy", busy > 0 ? idle_mean / busy : 0.0},
          {"sleeping_bodies", run.result.sleeping_bodies},
          {"messages", run.result.messages},
          {"worlds", worlds}};
}

int run_idle(IdleOptions& o) {
  Scene scene = make_scene("idle-territories", o.params);
  scene.settings.steps = o.steps;
  validate_scene(scene, "idle-territories");
  RunConfig base;
  base.steps = o.steps;
  base.territories = kTerritories;
  base.partition = "grid:8x1x1";
  base.threads = 0;  // a thread per world: thread_cpu_seconds is the world's own
  base.progress_seconds = 0;
  IdleRun on{"idle-skip", {}}, off{"no-idle-skip", {}};
  for (int r = 0; r < o.repeat; ++r)
    for (IdleRun* run : {&on, &off}) {
      RunConfig c = base;
      c.runtime.idle_territories = run == &on;
      RunResult res = run_scene(scene, c);
      if (r == 0 || cpu_ms_per_step(res.world_metrics.at(0)) < cpu_ms_per_step(run->result.world_metrics.at(0)))
        run->result = std::move(res);
    }
  nlohmann::json j = {{"bench", "idle-territories"},
                      {"bodies_per_region", o.params.n > 0 ? o.params.n : 200},
                      {"territories", kTerritories},
                      {"partition", base.partition},
                      {"steps", o.steps},
                      {"repeat", o.repeat},
                      {"runs", {run_json(on), run_json(off)}}};
  const bool same = on.result.state_hash == off.result.state_hash;
  j["hashes_equal"] = same;
  std::fprintf(stderr, "idle-territories bench: %d steps, 8 territories, least busy-world thread CPU of %d\n",
               o.steps, o.repeat);
  std::fprintf(stderr, "  %-14s %10s %14s %14s %14s  %s\n", "run", "busy ms", "idle max ms", "idle mean ms",
               "idle/busy", "state_hash");
  for (const nlohmann::json& run : j["runs"])
    std::fprintf(stderr, "  %-14s %10.4f %14.4f %14.4f %13.2f%%  %s\n", run["name"].get<std::string>().c_str(),
                 run["busy_cpu_ms_per_step"].get<double>(), run["idle_cpu_ms_per_step_max"].get<double>(),
                 run["idle_cpu_ms_per_step_mean"].get<double>(), 100.0 * run["idle_over_busy"].get<double>(),
                 run["state_hash"].get<std::string>().c_str());
  write_json(j, "-");
  if (!o.out.empty()) write_json(j, o.out);
  if (!same) std::fprintf(stderr, "idle-territories bench: the state hashes differ with the skip on and off\n");
  return same ? 0 : 1;
}

}  // namespace

Command add_idle_command(CLI::App& bench) {
  auto o = std::make_shared<IdleOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "idle-territories",
      "Eight territories, activity in one: each world's thread CPU per step with the idle skip on and off "
      "(idle_over_busy); JSON on stdout");
  cmd->add_option("--n", o->params.n, "Bodies per region (0: 200)")->check(CLI::Range(0, 1 << 20))->capture_default_str();
  cmd->add_option("--seed", o->params.seed, "Seed of the scene generator")->capture_default_str();
  cmd->add_option("--steps", o->steps, "Steps of every run")->check(CLI::Range(1, 1 << 24))->capture_default_str();
  cmd->add_option("--repeat", o->repeat, "Interleaved repeats; the one with the least busy-world CPU is kept")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Also write the JSON to this file");
  return {cmd, [o] { return run_idle(*o); }};
}

}  // namespace soda::cli
