// `soda lb` (docs/loadbalance.md, "Running an experiment"): a scene under
// each balance policy; CSV files and summary.json in --out, the summary JSON
// on stdout, a readable table on stderr.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "commands.h"
#include "soda/bench/lb_experiment.h"
#include "soda/scene/registry.h"
#include "soda/worlds/body_state.h"
#include "soda/scene/validate.h"

namespace soda::cli {
namespace {

struct LbOptions {
  std::string scene = "hotspot";
  SceneParams params;
  std::optional<int> steps;
  LbExperimentConfig experiment;
  std::string policies = "none,diffusive,rcb";
  std::string map_steps;
  bool no_baseline = false;
  std::string out;
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');)
    if (!part.empty()) parts.push_back(part);
  return parts;
}

std::vector<std::int64_t> parse_steps(const std::string& text, int steps) {
  std::vector<std::int64_t> out;
  if (text.empty()) {
    for (int q = 0; q <= 4; ++q) out.push_back(static_cast<std::int64_t>(steps) * q / 4);
    return out;
  }
  for (const std::string& part : split(text)) {
    std::size_t used = 0;
    long long v = -1;
    try {
      v = std::stoll(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != part.size() || v < 0 || v > steps)
      throw std::invalid_argument("--maps-at: '" + part + "' is not a step in 0.." + std::to_string(steps));
    out.push_back(v);
  }
  return out;
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) throw std::runtime_error("cannot write " + path.string());
}

void print_summary(const nlohmann::json& j) {
  std::fprintf(stderr, "soda lb: %s, %zu bodies, %d steps, %d territories (%s, %d threads), period %d, anticipation %d\n",
               j["scene"].get<std::string>().c_str(), j["bodies"].get<std::size_t>(), j["steps"].get<int>(),
               j["territories"].get<int>(), j["partition"].get<std::string>().c_str(), j["threads"].get<int>(),
               j["balance_options"]["period"].get<int>(), j["anticipation"].get<int>());
  std::fprintf(stderr, "  %-10s %9s %9s %9s %10s %10s %7s %7s %8s %9s  %s\n", "policy", "wall_s", "vs_stock", "vs_none",
               "imbalance", "(weighted)", "cells", "bodies", "lb_cpu_s", "lb_share", "state_hash");
  for (const nlohmann::json& p : j["policies"]) {
    const double vs_stock = p.contains("ratio_vs_baseline") ? p["ratio_vs_baseline"].get<double>() : 0.0;
    const double vs_none = p.contains("speedup_vs_none") ? p["speedup_vs_none"].get<double>() : 0.0;
    std::fprintf(stderr, "  %-10s %9.3f %9.3f %9.3f %10.3f %10.3f %7lld %7lld %8.3f %8.1f%%  %s\n",
                 p["policy"].get<std::string>().c_str(), p["wall_seconds"].get<double>(), vs_stock, vs_none,
                 p["imbalance_mean"].get<double>(), p["imbalance_weighted"].get<double>(),
                 p["cells_moved"].get<long long>(), p["bodies_moved"].get<long long>(),
                 p["lb_cpu_seconds"].get<double>(), 100.0 * p["lb_overhead_share"].get<double>(),
                 p["state_hash"].get<std::string>().c_str());
  }
  std::fprintf(stderr, "  imbalance: max / mean busy CPU of the worlds per step (thread CPU, so it holds on 2 cores "
                       "with more worlds than cores); state hashes %s; one territory %s: %s\n",
               j["hashes_equal"].get<bool>() ? "equal under every policy" : "DIFFER between policies",
               j["one_territory_state_hash"].get<std::string>().c_str(),
               j["state_hash_equals_one_territory"].get<bool>() ? "every policy's hash equals it" : "a policy's DIFFERS");
}

int run_lb(LbOptions& o) {
  Scene scene = load_or_make_scene(o.scene, o.params);
  if (o.steps) scene.settings.steps = *o.steps;
  validate_scene(scene, o.scene);
  o.experiment.run.steps = scene.settings.steps;
  // A registry scene's own inputs (rain's later waves), applied by the
  // PartitionedWorld under every policy.
  if (std::vector<UserInput> own = scene_inputs(o.scene, o.params); !own.empty()) {
    o.experiment.run.inputs = std::move(own);
    o.experiment.run.inputs_source = "scene '" + o.scene + "' (its inputs)";
    o.experiment.run.inputs_via_simulation = false;
  }
  if (o.experiment.run.partition.empty())
    o.experiment.run.partition = "grid:" + std::to_string(o.experiment.run.territories) + "x1x1";
  o.experiment.policies = split(o.policies);
  o.experiment.baseline = !o.no_baseline;
  const std::vector<std::int64_t> map_steps = parse_steps(o.map_steps, scene.settings.steps);
  if (!o.out.empty()) std::filesystem::create_directories(o.out);
  const LbExperimentResult r = run_lb_experiment(scene, o.experiment);
  const nlohmann::json j = lb_summary_json({o.scene, o.params, &scene, o.experiment.run}, o.experiment, r);
  print_summary(j);
  write_json(j, "-");
  if (!o.out.empty()) {
    const std::filesystem::path dir(o.out);
    write_json(j, (dir / "summary.json").string());
    std::ostringstream steps, balance, maps;
    write_steps_csv(steps, r);
    write_balance_csv(balance, r);
    write_maps_csv(maps, r, map_steps);
    write_file(dir / "steps.csv", steps.str());
    write_file(dir / "balance.csv", balance.str());
    write_file(dir / "maps.csv", maps.str());
    std::fprintf(stderr, "  wrote %s/{summary.json,steps.csv,balance.csv,maps.csv}; plots: /usr/bin/python3 "
                         "bench/plot_lb.py %s\n",
                 o.out.c_str(), o.out.c_str());
  }
  if (!r.equals_one_territory || !r.hashes_equal) {
    for (const LbPolicyRun& run : r.runs)
      if (!run.equals_one_territory)
        std::fprintf(stderr, "soda: error: lb: policy %s ends on %s, one territory on %s (load balancing changed "
                             "physics)\n",
                     run.policy.c_str(), hash_hex(run.best.state_hash).c_str(), hash_hex(r.one_territory_hash).c_str());
    return 1;
  }
  return 0;
}

}  // namespace

Command add_lb_command(CLI::App& app) {
  auto o = std::make_shared<LbOptions>();
  o->experiment.run.territories = 8;
  o->experiment.run.partition = "";  // grid:Kx1x1
  CLI::App* cmd = app.add_subcommand(
      "lb", "Load-balance experiment: one scene under each balance policy (same seed, same first map) beside one "
            "stock Bullet world; per-step CSV and summary.json in --out, summary JSON on stdout");
  cmd->add_option("--scene", o->scene, "Registry scene name or a .json scene file")->capture_default_str();
  cmd->add_option("--n", o->params.n, "Scene size (0: the scene's default)")->capture_default_str();
  cmd->add_option("--seed", o->params.seed, "Seed of the scene generator")->capture_default_str();
  cmd->add_option("--steps", o->steps, "Steps to run (default: the scene's)");
  cmd->add_option("--territories", o->experiment.run.territories, "Territories (K >= 2)")->capture_default_str();
  cmd->add_option("--partition", o->experiment.run.partition, "The first map: kmeans | rcb | grid:AxBxC | file (default: grid:Kx1x1, strips along x)");
  cmd->add_option("--threads", o->experiment.run.threads, "Threads stepping the worlds (0: one per world)")
      ->capture_default_str();
  cmd->add_option("--solver-threads", o->experiment.run.runtime.solver_threads,
                  "Threads that solve the colours of a large island (a pool shared by the worlds; "
                  "docs/coloured-solve.md)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_option("--solver-guests", o->experiment.run.runtime.solver_guests,
                  "One thread per world: world threads waiting for a message that take tasks of another world's "
                  "solve meanwhile, their CPU counted as their world's (-1: the cores the run leaves free; 0: none)")
      ->check(CLI::Range(-1, 256))
      ->capture_default_str();
  cmd->add_option("--policies", o->policies, "Comma-separated policies: none, diffusive, rcb, churn")
      ->capture_default_str();
  add_balance_options(*cmd, o->experiment.run.runtime.balance);
  cmd->add_option("--anticipation", o->experiment.run.runtime.anticipation, "Speculation: steps past the commit horizon")
      ->check(CLI::Range(0, 1 << 20))
      ->capture_default_str();
  cmd->add_option("--sync-test", o->experiment.run.sync_test, "SyncTest depth (0: off)")
      ->check(CLI::Range(0, 1 << 20))
      ->capture_default_str();
  cmd->add_flag("--validate", o->experiment.run.runtime.validate, "Check ownership and pair holders after every step");
  cmd->add_flag("--pin", o->experiment.run.runtime.pin, "Pin world threads to cores");
  cmd->add_option("--repeat", o->experiment.repeat, "Interleaved repeats; the fastest of each policy is kept")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_flag("--no-baseline", o->no_baseline, "Skip the stock Bullet world (no ratio_vs_baseline)");
  cmd->add_option("--maps-at", o->map_steps,
                  "Comma-separated steps whose territory maps go to maps.csv (default: 0, 1/4, 1/2, 3/4, end)");
  cmd->add_option("--out", o->out, "Directory for summary.json, steps.csv, balance.csv and maps.csv");
  return {cmd, [o] { return run_lb(*o); }};
}

}  // namespace soda::cli
