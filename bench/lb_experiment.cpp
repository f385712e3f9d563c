// `soda lb`: a scene under each balance policy, side by side (lb_experiment.h).
#include "soda/bench/lb_experiment.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

#include <spdlog/spdlog.h>

#include "soda/grid/partition.h"
#include "soda/worlds/body_state.h"

namespace soda {
namespace {

void check_config(const LbExperimentConfig& config) {
  if (config.policies.empty()) throw std::invalid_argument("soda lb: no policy to run (--policies)");
  std::set<std::string> seen;
  for (const std::string& p : config.policies) {
    if (!seen.insert(p).second) throw std::invalid_argument("soda lb: policy '" + p + "' named twice in --policies");
    BalanceOptions o = config.run.runtime.balance;
    o.policy = p;
    (void)make_balance_policy(o);  // throws BalanceError for an unknown name or bad knobs, before any run
  }
  if (config.run.territories < 2)
    throw std::invalid_argument("soda lb: --territories must be >= 2 (one territory has nothing to balance), got " +
                                std::to_string(config.run.territories));
  if (config.repeat < 1) throw std::invalid_argument("soda lb: --repeat must be >= 1");
}

RunConfig policy_config(const LbExperimentConfig& config, const std::string& policy) {
  RunConfig c = config.run;
  c.world = WorldKind::Canonical;
  c.runtime.balance.policy = policy;
  return c;
}

RunConfig stock_config(const LbExperimentConfig& config) {
  RunConfig c = config.run;
  c.world = WorldKind::Stock;
  c.territories = 1;
  c.runtime.balance = {};
  c.runtime.anticipation = 0;
  c.sync_test = 0;
  c.runtime.validate = false;
  return c;
}

// The reference every policy must end on: the same scene, steps and inputs
// on one territory (one canonical world, nothing to balance or bet on).
RunConfig one_territory_config(const LbExperimentConfig& config) {
  RunConfig c = config.run;
  c.world = WorldKind::Canonical;
  c.territories = 1;
  c.partition = "kmeans";
  c.runtime.balance = {};
  c.runtime.anticipation = 0;
  c.sync_test = 0;
  c.runtime.validate = false;
  return c;
}

// Keeps the fastest of a run's repeats.
void keep_best(std::optional<RunResult>& best, RunResult r) {
  if (!best || r.wall_seconds < best->wall_seconds) best = std::move(r);
}

}  // namespace

Imbalance imbalance_of(const std::vector<StepLoads>& loads) {
  Imbalance im;
  double sum_max = 0, sum_mean = 0;
  for (const StepLoads& step : loads) {
    if (step.worlds.empty()) continue;
    double max = 0, sum = 0;
    for (const WorldStepLoad& w : step.worlds) {
      max = std::max(max, w.busy_seconds);
      sum += w.busy_seconds;
    }
    const double mean = sum / static_cast<double>(step.worlds.size());
    if (!(mean > 0)) continue;
    im.mean += max / mean;
    im.max = std::max(im.max, max / mean);
    sum_max += max;
    sum_mean += mean;
    ++im.steps;
  }
  if (im.steps > 0) im.mean /= static_cast<double>(im.steps);
  if (sum_mean > 0) im.weighted = sum_max / sum_mean;
  return im;
}

LbExperimentResult run_lb_experiment(const Scene& scene, const LbExperimentConfig& config) {
  check_config(config);
  LbExperimentResult r;
  r.first_map = make_partition(config.run.partition, scene, config.run.territories, grid_options(config.run));
  std::vector<std::optional<RunResult>> best(config.policies.size());
  r.runs.resize(config.policies.size());
  std::optional<RunResult> stock;
  // The stock world takes no inputs: a scene with inputs has no baseline.
  const bool baseline = config.baseline && !config.run.inputs;
  if (config.baseline && !baseline)
    spdlog::warn("soda lb: no stock baseline for a scene with inputs (the stock world does not take them)");
  const int runs = static_cast<int>(config.policies.size()) + (baseline ? 1 : 0);
  for (int rep = 0; rep < config.repeat; ++rep) {
    for (int k = 0; k < runs; ++k) {
      const int i = rep % 2 == 0 ? k : runs - 1 - k;  // interleaved: drift of the machine hits every run alike
      if (i == static_cast<int>(config.policies.size())) {
        spdlog::info("soda lb: stock Bullet world (baseline), repeat {}/{}", rep + 1, config.repeat);
        RunResult s = run_scene(scene, stock_config(config));
        r.stock_walls.push_back(s.wall_seconds);
        keep_best(stock, std::move(s));
        continue;
      }
      const std::string& policy = config.policies[static_cast<std::size_t>(i)];
      spdlog::info("soda lb: policy {}, repeat {}/{}", policy, rep + 1, config.repeat);
      RunResult run = run_scene(scene, policy_config(config, policy));
      LbPolicyRun& out = r.runs[static_cast<std::size_t>(i)];
      out.policy = policy;
      out.walls.push_back(run.wall_seconds);
      out.hashes.push_back(run.state_hash);
      spdlog::info("soda lb: policy {}: {:.3f} s, state hash {}", policy, run.wall_seconds, hash_hex(run.state_hash));
      keep_best(best[static_cast<std::size_t>(i)], std::move(run));
    }
  }
  for (std::size_t i = 0; i < r.runs.size(); ++i) r.runs[i].best = std::move(*best[i]);
  r.stock = std::move(stock);
  r.hashes_equal = true;
  const std::uint64_t h = r.runs.front().hashes.front();
  for (const LbPolicyRun& run : r.runs)
    for (std::uint64_t other : run.hashes) r.hashes_equal = r.hashes_equal && other == h;
  spdlog::info("soda lb: one territory (the hash every policy must end on)");
  r.one_territory_hash = run_scene(scene, one_territory_config(config)).state_hash;
  r.equals_one_territory = true;
  for (LbPolicyRun& run : r.runs) {
    run.equals_one_territory = std::all_of(run.hashes.begin(), run.hashes.end(),
                                           [&](std::uint64_t x) { return x == r.one_territory_hash; });
    r.equals_one_territory = r.equals_one_territory && run.equals_one_territory;
  }
  return r;
}

TerritoryMap map_at(const TerritoryMap& first, const std::vector<BalanceRecord>& log, std::int64_t step) {
  TerritoryMap map = first;
  for (const BalanceRecord& rec : log) {
    if (rec.step > step) break;
    if (rec.moves.empty()) continue;
    std::vector<std::pair<CellCoord, WorldId>> changes;
    changes.reserve(rec.moves.size());
    for (const CellMove& m : rec.moves) changes.emplace_back(m.cell, m.to);
    map = map.reassigned(changes);
  }
  return map;
}

void write_steps_csv(std::ostream& out, const LbExperimentResult& r) {
  out << "policy,step,world,busy_ms,wait_ms,bodies,cells,lead,islands,cells_out,cells_in,bodies_out,bodies_in\n";
  char line[256];
  const BalanceRecord no_balance;  // steps without a balance step moved nothing
  for (const LbPolicyRun& run : r.runs) {
    std::map<std::int64_t, const BalanceRecord*> balanced;  // by the step a balance step ended
    for (const BalanceRecord& rec : run.best.balance_log) balanced[rec.step] = &rec;
    for (const StepLoads& step : run.best.step_loads) {
      const auto it = balanced.find(step.step);
      const BalanceRecord& b = it == balanced.end() ? no_balance : *it->second;
      for (std::size_t w = 0; w < step.worlds.size(); ++w) {
        const WorldStepLoad& l = step.worlds[w];
        auto of = [w](const std::vector<std::int64_t>& v) { return static_cast<long long>(w < v.size() ? v[w] : 0); };
        std::snprintf(line, sizeof line, ",%lld,%zu,%.6f,%.6f,%d,%d,%d,%d,%lld,%lld,%lld,%lld\n",
                      static_cast<long long>(step.step), w, l.busy_seconds * 1e3, l.wait_seconds * 1e3, l.bodies,
                      l.cells, l.lead, l.islands, of(b.cells_out), of(b.cells_in), of(b.bodies_out), of(b.bodies_in));
        out << run.policy << line;
      }
    }
  }
}

void write_balance_csv(std::ostream& out, const LbExperimentResult& r) {
  out << "policy,step,cells_moved,bodies_moved,gather_ms,decide_ms,apply_ms,wall_ms,model_error\n";
  char line[256];
  for (const LbPolicyRun& run : r.runs)
    for (const BalanceRecord& rec : run.best.balance_log) {
      std::snprintf(line, sizeof line, ",%lld,%lld,%lld,%.4f,%.4f,%.4f,%.4f,", static_cast<long long>(rec.step),
                    static_cast<long long>(rec.cells_moved), static_cast<long long>(rec.bodies_moved),
                    rec.gather_cpu_seconds * 1e3, rec.decide_cpu_seconds * 1e3, rec.apply_cpu_seconds * 1e3,
                    rec.wall_seconds * 1e3);
      out << run.policy << line;
      // Empty where the policy had no model or the model no data yet.
      if (rec.prediction.samples > 0) out << rec.prediction.weighted_relative_error;
      out << '\n';
    }
}

void write_maps_csv(std::ostream& out, const LbExperimentResult& r, const std::vector<std::int64_t>& steps) {
  out << "policy,step,x,y,z,owner\n";
  const CellBox& box = r.first_map.box();
  char line[128];
  for (const LbPolicyRun& run : r.runs)
    for (std::int64_t step : steps) {
      const TerritoryMap map = map_at(r.first_map, run.best.balance_log, step);
      for (int x = box.lo.x; x <= box.hi.x; ++x)
        for (int y = box.lo.y; y <= box.hi.y; ++y)
          for (int z = box.lo.z; z <= box.hi.z; ++z) {
            std::snprintf(line, sizeof line, ",%lld,%d,%d,%d,%d\n", static_cast<long long>(step), x, y, z,
                          map.owner(CellCoord{x, y, z}));
            out << run.policy << line;
          }
    }
}

nlohmann::json lb_summary_json(const RunDescription& d, const LbExperimentConfig& config,
                               const LbExperimentResult& r) {
  const RunResult& first = r.runs.front().best;
  const BalanceOptions& o = config.run.runtime.balance;
  nlohmann::json j = {
      {"benchmark", "lb"},
      {"scene", d.scene},
      {"params", {{"n", d.params.n}, {"seed", d.params.seed}, {"random_scale", d.params.random_scale}}},
      {"precision", kPrecisionName},
      {"bodies", first.bodies},
      {"dynamic_bodies", first.dynamic_bodies},
      {"steps", first.steps},
      {"dt", d.resolved->settings.dt},
      {"territories", first.territories},
      {"partition", config.run.partition},
      {"schedule", first.schedule},
      {"threads", first.threads},
      {"solver_threads", config.run.runtime.solver_threads},
      {"solver_guests", config.run.runtime.solver_guests},
      {"anticipation", config.run.runtime.anticipation},
      {"sync_test", config.run.sync_test},
      {"validate", config.run.runtime.validate},
      {"balance_options",
       {{"period", o.period}, {"seed", o.seed}, {"smoothing", o.smoothing}, {"overload", o.overload},
        {"underload", o.underload}, {"max_cells_per_move", o.max_cells_per_move}}},
  };
  j["repeat"] = config.repeat;
  j["hashes_equal"] = r.hashes_equal;
  j["one_territory_state_hash"] = hash_hex(r.one_territory_hash);
  j["state_hash_equals_one_territory"] = r.equals_one_territory;
  j["state_hash"] = hash_hex(r.runs.front().best.state_hash);
  if (r.stock) {
    j["baseline"] = {{"world", "stock"}, {"wall_seconds", r.stock->wall_seconds}, {"walls", r.stock_walls},
                     {"state_hash", hash_hex(r.stock->state_hash)}, {"sleeping_bodies", r.stock->sleeping_bodies}};
  }
  const LbPolicyRun* none = nullptr;
  for (const LbPolicyRun& run : r.runs)
    if (run.policy == "none") none = &run;
  nlohmann::json policies = nlohmann::json::array();
  for (const LbPolicyRun& run : r.runs) {
    const RunResult& b = run.best;
    const Imbalance im = imbalance_of(b.step_loads);
    const BalanceTotals t = balance_totals(b.balance_log);
    nlohmann::json p = {{"policy", run.policy},
                        {"wall_seconds", b.wall_seconds},
                        {"walls", run.walls},
                        {"makespan_seconds", b.wall_seconds},
                        {"busy_cpu_seconds", b.cpu_seconds},  // run_scene sums the worlds' cpu_seconds
                        {"imbalance_mean", im.mean},
                        {"imbalance_weighted", im.weighted},
                        {"imbalance_max", im.max},
                        {"imbalance_steps", im.steps},
                        {"balance_steps", t.balance_steps},
                        {"cells_moved", t.cells_moved},
                        {"bodies_moved", t.bodies_moved},
                        {"lb_cpu_seconds", t.cpu_seconds()},
                        {"lb_gather_cpu_seconds", t.gather_cpu_seconds},
                        {"lb_decide_cpu_seconds", t.decide_cpu_seconds},
                        {"lb_apply_cpu_seconds", t.apply_cpu_seconds},
                        {"lb_wall_seconds", t.wall_seconds},
                        {"lb_overhead_share", b.wall_seconds > 0 ? t.wall_seconds / b.wall_seconds : 0.0},
                        {"state_hash", hash_hex(b.state_hash)},
                        {"state_hash_equals_one_territory", run.equals_one_territory}};
    // The cost model's out-of-sample error over the balance steps where it had data.
    double error_sum = 0, error_max = 0;
    int predicted = 0;
    for (const BalanceRecord& rec : b.balance_log) {
      if (rec.prediction.samples == 0) continue;
      ++predicted;
      error_sum += rec.prediction.weighted_relative_error;
      error_max = std::max(error_max, rec.prediction.weighted_relative_error);
    }
    if (predicted > 0) {
      p["model_error_weighted_mean"] = error_sum / predicted;
      p["model_error_weighted_max"] = error_max;
      p["model_error_steps"] = predicted;
    }
    if (r.stock && b.wall_seconds > 0) p["ratio_vs_baseline"] = r.stock->wall_seconds / b.wall_seconds;
    if (none && b.wall_seconds > 0) p["speedup_vs_none"] = none->best.wall_seconds / b.wall_seconds;
    policies.push_back(std::move(p));
  }
  j["policies"] = std::move(policies);
  return j;
}

}  // namespace soda
