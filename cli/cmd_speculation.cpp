// `soda bench speculation` (docs/speculation-bench.md): JSON on stdout (and
// --out FILE), a readable summary on stderr.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "soda/bench/speculation.h"
#include "soda/scene/registry.h"
#include "soda/scene/validate.h"
#include "soda/worlds/body_state.h"

namespace soda::cli {
namespace {

struct SpeculationOptions {
  std::string scene = "alternating-load";
  SceneParams params;
  std::optional<int> steps;
  SpeculationBenchConfig bench;
  std::string out;
};

void print_worlds(const SpeculationRun& run) {
  for (const WorldMetrics& m : run.best.world_metrics)
    std::fprintf(stderr,
                 "  %-13s world %d: cpu %.3f s, blocked %.3f s, lead max %lld mean %.1f, %llu bets (%llu lost), "
                 "%llu rollbacks, %llu steps rolled back (%llu rejoined), %llu bodies re-solved (%.1f per rollback), "
                 "%llu replayed, rollback cpu %.3f s\n",
                 run.name.c_str(), m.world, m.cpu_seconds, m.blocked_seconds, static_cast<long long>(m.lead_max),
                 m.lead_mean, static_cast<unsigned long long>(m.bets), static_cast<unsigned long long>(m.bets_lost),
                 static_cast<unsigned long long>(m.rollbacks), static_cast<unsigned long long>(m.steps_rolled_back),
                 static_cast<unsigned long long>(m.steps_rejoined),
                 static_cast<unsigned long long>(m.bodies_resolved),
                 bodies_resolved_per_rollback(m), static_cast<unsigned long long>(m.bodies_replayed),
                 m.rollback_cpu_seconds);
}

void print_summary(const nlohmann::json& j, const SpeculationBenchResult& r) {
  std::fprintf(stderr, "speculation bench: %s, %zu bodies, %d steps, %d territories (%s), anticipation %d, min of "
               "%d interleaved repeats\n",
               j["scene"].get<std::string>().c_str(), j["bodies"].get<std::size_t>(), j["steps"].get<int>(),
               j["territories"].get<int>(), j["partition"].get<std::string>().c_str(), j["anticipation"].get<int>(),
               j["repeat"].get<int>());
  std::fprintf(stderr, "  %-13s %9s %9s %12s  %s\n", "run", "wall_s", "vs_stock", "vs_lockstep", "state_hash");
  for (const nlohmann::json& run : j["runs"]) {
    char vs_lockstep[32] = "";
    if (run.contains("speedup_vs_lockstep"))
      std::snprintf(vs_lockstep, sizeof vs_lockstep, "%.3f", run["speedup_vs_lockstep"].get<double>());
    std::fprintf(stderr, "  %-13s %9.3f %9.3f %12s  %s\n", run["name"].get<std::string>().c_str(),
                 run["wall_seconds"].get<double>(), run["ratio_vs_baseline"].get<double>(), vs_lockstep,
                 run["state_hash"].get<std::string>().c_str());
  }
  std::fprintf(stderr,
               "  speed-up over lockstep: propagate %.3f, recompute %.3f (target >= 1.3); bound B %.3f; modelled at "
               "anticipation %d: %.3f (a model, not a measurement)\n",
               j["speedup_propagate_vs_lockstep"].get<double>(), j["speedup_recompute_vs_lockstep"].get<double>(),
               j["bound"].get<double>(), j["anticipation"].get<int>(), j["modelled_speedup"].get<double>());
  for (const char* name : {"lockstep", "propagate", "recompute"}) print_worlds(r.run(name));
  const nlohmann::json& ratio = j["bodies_resolved_propagate_over_recompute"];
  if (ratio.is_null())
    std::fprintf(stderr, "  bodies re-solved, propagate / recompute: n/a (recompute re-solved none)\n");
  else {
    const nlohmann::json& per_bet = j["bodies_resolved_per_lost_bet_propagate_over_recompute"];
    std::fprintf(stderr, "  bodies re-solved, propagate / recompute: %.3f in all, %.3f per lost bet\n",
                 ratio.get<double>(), per_bet.is_null() ? 0.0 : per_bet.get<double>());
  }
  const nlohmann::json& all = j["all_repeats"];
  if (!all["bodies_resolved_propagate_over_recompute"].is_null()) {
    const nlohmann::json& per_bet = all["bodies_resolved_per_lost_bet_propagate_over_recompute"];
    std::fprintf(stderr,
                 "  over all %d repeats: %.3f in all, %.3f per lost bet (propagate %llu bodies for %llu lost bets, "
                 "%llu replayed; recompute %llu for %llu)\n",
                 j["repeat"].get<int>(), all["bodies_resolved_propagate_over_recompute"].get<double>(),
                 per_bet.is_null() ? 0.0 : per_bet.get<double>(),
                 all["propagate"]["bodies_resolved"].get<unsigned long long>(),
                 all["propagate"]["bets_lost"].get<unsigned long long>(),
                 all["propagate"]["bodies_replayed"].get<unsigned long long>(),
                 all["recompute"]["bodies_resolved"].get<unsigned long long>(),
                 all["recompute"]["bets_lost"].get<unsigned long long>());
  }
  for (const nlohmann::json& run : j["runs"])
    if (run.contains("time_saved_vs_lockstep_seconds") && run["anticipation"].get<int>() > 0)
      std::fprintf(stderr, "  %s: time saved against lockstep %.3f s, rollback CPU %.1f %% of its CPU\n",
                   run["name"].get<std::string>().c_str(), run["time_saved_vs_lockstep_seconds"].get<double>(),
                   100.0 * run["speculation"]["rollback_cpu_share"].get<double>());
  std::fprintf(stderr, "  state hashes: %s\n",
               r.hashes_equal ? ("every partitioned run equals one territory's, " +
                                 j["one_territory_state_hash"].get<std::string>())
                                    .c_str()
                              : "DIFFERENT (see runs[].state_hash)");
}

int run_speculation(SpeculationOptions& o) {
  Scene scene = load_or_make_scene(o.scene, o.params);
  if (o.steps) scene.settings.steps = *o.steps;
  validate_scene(scene, o.scene);
  o.bench.run.steps = scene.settings.steps;
  const SpeculationBenchResult r = bench_speculation(scene, o.bench);
  const nlohmann::json j = speculation_bench_json({o.scene, o.params, &scene, o.bench.run}, o.bench, r);
  print_summary(j, r);
  write_json(j, "-");
  if (!o.out.empty()) write_json(j, o.out);
  if (!r.hashes_equal) {
    std::fprintf(stderr, "soda: error: speculation bench: the state hashes differ from the one-territory run's\n");
    return 1;
  }
  return 0;
}

}  // namespace

Command add_speculation_command(CLI::App& bench) {
  auto o = std::make_shared<SpeculationOptions>();
  o->bench.run.territories = 2;
  CLI::App* cmd = bench.add_subcommand(
      "speculation",
      "Speculation against lockstep on a scene whose load alternates between territories: stock, one territory, "
      "K territories with anticipation 0 and A (propagate and recompute); JSON on stdout");
  cmd->add_option("--scene", o->scene, "Registry scene name or a .json scene file")->capture_default_str();
  cmd->add_option("--n", o->params.n, "Scene size (0: the scene's default)")->capture_default_str();
  cmd->add_option("--seed", o->params.seed, "Seed of the scene generator")->capture_default_str();
  cmd->add_option("--steps", o->steps, "Steps to run (default: the scene's, 600)");
  cmd->add_option("--territories", o->bench.run.territories, "Territories (K >= 2) of the partitioned runs")
      ->capture_default_str();
  cmd->add_option("--partition", o->bench.run.partition, "kmeans | rcb | grid:AxBxC | territory-map file")
      ->capture_default_str();
  cmd->add_option("--threads", o->bench.run.threads, "Threads of the partitioned runs (0: one per world)")
      ->capture_default_str();
  cmd->add_flag("--serialise", o->bench.run.serialise, "Messages between worlds through bytes");
  cmd->add_flag("--pin", o->bench.run.runtime.pin, "Pin world threads to cores");
  cmd->add_option("--anticipation", o->bench.anticipation,
                  "Scene steps a world may run past the commit horizon in the speculative runs")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd->add_option("--checkpoint-every", o->bench.run.runtime.checkpoint_every,
                  "Internal steps between the states a world keeps to roll back to")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd->add_flag("--eager-bets", o->bench.run.runtime.eager_bets,
                "Bet also on neighbours whose newest ghosts were not empty in the speculative runs");
  cmd->add_option("--slow-world0", o->bench.run.slow_world0_ms,
                  "Milliseconds world 0's thread sleeps after each step in the partitioned runs (a slow world)")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  cmd->add_option("--repeat", o->bench.repeat, "Interleaved repeats; the fastest of each run is kept")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Also write the JSON to this file");
  return {cmd, [o] { return run_speculation(*o); }};
}

}  // namespace soda::cli
