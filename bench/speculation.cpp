#include "soda/bench/speculation.h"

#include <algorithm>
#include <stdexcept>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "soda/worlds/body_state.h"

namespace soda {
namespace {

// CPU time per world in windows of this many internal steps: the load per
// world over time, in the JSON (a plot's input), not the whole series.
constexpr std::size_t kLoadWindowSteps = 25;

std::size_t step_count(const std::vector<WorldMetrics>& worlds) {
  std::size_t steps = 0;
  for (const WorldMetrics& w : worlds) steps = std::max(steps, w.cpu_step_ms.size());
  return steps;
}

double step_ms(const WorldMetrics& w, std::size_t s) { return s < w.cpu_step_ms.size() ? w.cpu_step_ms[s] : 0.0; }

nlohmann::json world_json(const WorldMetrics& m) {
  nlohmann::json j = {{"world", m.world},
                      {"cpu_seconds", m.cpu_seconds},
                      {"blocked_seconds", m.blocked_seconds},
                      {"owned_bodies", m.owned_bodies},
                      {"ghosts_sent", m.ghosts_sent},
                      {"migrations_out", m.migrations_out}};
  j.update(speculation_json(m));
  return j;
}

nlohmann::json load_by_window_json(const std::vector<WorldMetrics>& worlds) {
  nlohmann::json j = nlohmann::json::array();
  for (const WorldMetrics& w : worlds) {
    std::vector<double> windows;
    for (std::size_t s = 0; s < w.cpu_step_ms.size(); ++s) {
      if (s % kLoadWindowSteps == 0) windows.push_back(0.0);
      windows.back() += w.cpu_step_ms[s];
    }
    j.push_back({{"world", w.world}, {"cpu_ms", windows}});
  }
  return j;
}

}  // namespace

const SpeculationRun& SpeculationBenchResult::run(const std::string& name) const {
  for (const SpeculationRun& r : runs)
    if (r.name == name) return r;
  throw std::logic_error("speculation bench: no run named " + name);
}

SpeculationBenchResult bench_speculation(const Scene& scene, const SpeculationBenchConfig& config) {
  if (config.repeat < 1) throw std::invalid_argument("--repeat must be >= 1");
  if (config.run.territories < 2) throw std::invalid_argument("--territories must be >= 2 (speculation bets on neighbours)");
  if (config.anticipation < 1) throw std::invalid_argument("--anticipation must be >= 1 (0 is the lockstep run)");
  SpeculationBenchResult out;
  for (const char* name : SpeculationBenchResult::names) {
    SpeculationRun r;
    r.name = name;
    r.config = config.run;
    r.config.runtime.anticipation = 0;
    r.config.runtime.rollback = PartitionedOptions::Rollback::Propagate;
    const std::string n = name;
    if (n == "stock" || n == "one-territory") {
      r.config.territories = 1;
      r.config.world = n == "stock" ? WorldKind::Stock : WorldKind::Canonical;
      if (n == "stock") r.config.shuffle_seed = 0;
    } else if (n != "lockstep") {
      r.config.runtime.anticipation = config.anticipation;
      r.config.runtime.rollback =
          n == "propagate" ? PartitionedOptions::Rollback::Propagate : PartitionedOptions::Rollback::Recompute;
    }
    out.runs.push_back(std::move(r));
  }
  const int count = static_cast<int>(out.runs.size());
  for (int i = 0; i < config.repeat; ++i) {
    for (int k = 0; k < count; ++k) {
      SpeculationRun& r = out.runs[static_cast<std::size_t>(i % 2 == 0 ? k : count - 1 - k)];
      RunResult result = run_scene(scene, r.config);
      r.walls.push_back(result.wall_seconds);
      r.hashes.push_back(result.state_hash);
      const WorldMetrics t = total_metrics(result.world_metrics);
      r.totals_all.bets_lost += t.bets_lost;
      r.totals_all.rollbacks += t.rollbacks;
      r.totals_all.bodies_resolved += t.bodies_resolved;
      r.totals_all.bodies_replayed += t.bodies_replayed;
      if (r.walls.size() == 1 || result.wall_seconds < r.best.wall_seconds) r.best = std::move(result);
    }
    std::string line;
    for (const SpeculationRun& r : out.runs) line += fmt::format(" {} {:.3f} s", r.name, r.walls.back());
    spdlog::info("repeat {}/{}:{}", i + 1, config.repeat, line);
  }
  const std::uint64_t reference = out.run("one-territory").hashes.front();
  out.hashes_equal = true;
  for (const SpeculationRun& r : out.runs)
    if (r.name != "stock")
      for (std::uint64_t h : r.hashes) out.hashes_equal = out.hashes_equal && h == reference;
  return out;
}

double alternation_bound(const std::vector<WorldMetrics>& worlds) {
  double largest_total = 0;
  for (const WorldMetrics& w : worlds) {
    double total = 0;
    for (double ms : w.cpu_step_ms) total += ms;
    largest_total = std::max(largest_total, total);
  }
  return largest_total > 0 ? slowest_world_cpu_seconds(worlds) * 1e3 / largest_total : 0.0;
}

double bounded_lead_speedup(const std::vector<WorldMetrics>& worlds, std::int64_t lead) {
  const std::size_t steps = step_count(worlds);
  const double lockstep = slowest_world_cpu_seconds(worlds) * 1e3;
  if (steps == 0 || lockstep <= 0) return 0.0;
  if (lead <= 1) return 1.0;
  // finish[w][s]: when world w finishes internal step s + 1 (ms from the start).
  const std::size_t k = worlds.size();
  std::vector<std::vector<double>> finish(k, std::vector<double>(steps, 0.0));
  const std::size_t gap = static_cast<std::size_t>(lead);
  for (std::size_t s = 0; s < steps; ++s)
    for (std::size_t w = 0; w < k; ++w) {
      double start = s > 0 ? finish[w][s - 1] : 0.0;
      // Step s + 1 may begin once every other world has finished step s + 1 - lead.
      if (s >= gap)
        for (std::size_t o = 0; o < k; ++o)
          if (o != w) start = std::max(start, finish[o][s - gap]);
      finish[w][s] = start + step_ms(worlds[w], s);
    }
  double end = 0;
  for (std::size_t w = 0; w < k; ++w) end = std::max(end, finish[w][steps - 1]);
  return end > 0 ? lockstep / end : 0.0;
}

nlohmann::json speculation_bench_json(const RunDescription& d, const SpeculationBenchConfig& config,
                                      const SpeculationBenchResult& r) {
  const SceneSettings& st = d.resolved->settings;
  const SpeculationRun& stock = r.run("stock");
  const SpeculationRun& one = r.run("one-territory");
  const SpeculationRun& lockstep = r.run("lockstep");
  const double baseline = stock.best.wall_seconds;
  const auto ratio = [](double a, double b) { return b > 0 ? a / b : 0.0; };
  nlohmann::json runs = nlohmann::json::array();
  for (const SpeculationRun& run : r.runs) {
    const RunResult& b = run.best;
    nlohmann::json j = {{"name", run.name},
                        {"world", world_kind_name(b.world)},
                        {"territories", b.territories},
                        {"anticipation", run.config.runtime.anticipation},
                        {"rollback", run.config.runtime.anticipation > 0 ? rollback_name(run.config.runtime.rollback) : "none"},
                        {"wall_seconds", b.wall_seconds},
                        {"wall_seconds_all", run.walls},
                        {"ratio_vs_baseline", ratio(baseline, b.wall_seconds)},
                        {"cpu_seconds", b.cpu_seconds},
                        {"state_hash", hash_hex(b.state_hash)},
                        {"sleeping_bodies", b.sleeping_bodies}};
    if (b.territories > 1) {
      j["speedup_vs_lockstep"] = ratio(lockstep.best.wall_seconds, b.wall_seconds);
      // The thesis' worth of anticipation with Rollback and Propagate: the
      // time of computing every step just in time (lockstep) minus the time
      // with speculation, rollbacks included; negative when it loses.
      j["time_saved_vs_lockstep_seconds"] = lockstep.best.wall_seconds - b.wall_seconds;
      j["schedule"] = b.schedule;
      j["threads"] = b.threads;
      j["messages"] = b.messages;
      j["slowest_world_cpu_seconds"] = slowest_world_cpu_seconds(b.world_metrics);
      j["speculation"] = speculation_json(total_metrics(b.world_metrics));
      nlohmann::json worlds = nlohmann::json::array();
      for (const WorldMetrics& m : b.world_metrics) worlds.push_back(world_json(m));
      j["worlds"] = std::move(worlds);
    }
    runs.push_back(std::move(j));
  }
  const std::int64_t lead = static_cast<std::int64_t>(config.anticipation) * st.substeps;
  const WorldMetrics propagate_totals = total_metrics(r.run("propagate").best.world_metrics);
  const WorldMetrics recompute_totals = total_metrics(r.run("recompute").best.world_metrics);
  const double per_bet_recompute = bodies_resolved_per_lost_bet(recompute_totals);
  const std::uint64_t propagate_resolved = propagate_totals.bodies_resolved;
  const std::uint64_t recompute_resolved = recompute_totals.bodies_resolved;
  const double speedup = ratio(lockstep.best.wall_seconds, r.run("propagate").best.wall_seconds);
  // The same ratios over every repeat: a run loses few bets on a small
  // scene, and which ones decides its figure.
  const WorldMetrics& propagate_all = r.run("propagate").totals_all;
  const WorldMetrics& recompute_all = r.run("recompute").totals_all;
  const double per_bet_recompute_all = bodies_resolved_per_lost_bet(recompute_all);
  return {
      {"benchmark", "speculation"},
      {"scene", d.scene},
      {"params", {{"n", d.params.n}, {"seed", d.params.seed}, {"random_scale", d.params.random_scale}}},
      {"seed", d.params.seed},
      {"precision", kPrecisionName},
      {"dt", st.dt},
      {"substeps", st.substeps},
      {"iterations", st.iterations},
      {"steps", d.config.steps},
      {"bodies", d.resolved->bodies.size()},
      {"dynamic_bodies", d.resolved->dynamic_count()},
      {"territories", d.config.territories},
      {"partition", d.config.partition},
      {"anticipation", config.anticipation},
      {"checkpoint_every", config.run.runtime.checkpoint_every},
      {"eager_bets", config.run.runtime.eager_bets},
      {"slow_world0_ms", config.run.slow_world0_ms},
      {"repeat", config.repeat},
      {"baseline", "stock btDiscreteDynamicsWorld, one world, same scene, same process"},
      {"baseline_wall_seconds", baseline},
      {"runs", std::move(runs)},
      {"speedup_propagate_vs_lockstep", speedup},
      {"speedup_recompute_vs_lockstep", ratio(lockstep.best.wall_seconds, r.run("recompute").best.wall_seconds)},
      {"lockstep_speedup_vs_one_territory", ratio(one.best.wall_seconds, lockstep.best.wall_seconds)},
      {"bound", alternation_bound(lockstep.best.world_metrics)},
      {"bound_note",
       "from the lockstep run's per-world CPU time per step: sum over steps of the slowest world's time / the "
       "largest world's total; the most any speculation can gain over lockstep"},
      {"modelled_speedup", bounded_lead_speedup(lockstep.best.world_metrics, lead)},
      {"modelled_speedup_note",
       "model, not a measurement: the lockstep run's per-step CPU times replayed with a world's lead over the "
       "slowest other world capped at the anticipation, speculation itself free"},
      {"load_window_steps", kLoadWindowSteps},
      {"lockstep_load_by_window", load_by_window_json(lockstep.best.world_metrics)},
      {"bodies_resolved_propagate_over_recompute",
       recompute_resolved ? nlohmann::json(static_cast<double>(propagate_resolved) /
                                           static_cast<double>(recompute_resolved))
                          : nlohmann::json(nullptr)},
      {"bodies_resolved_per_lost_bet_propagate_over_recompute",
       per_bet_recompute > 0 ? nlohmann::json(bodies_resolved_per_lost_bet(propagate_totals) / per_bet_recompute)
                             : nlohmann::json(nullptr)},
      {"all_repeats",
       {{"note", "speculation counters of propagate and recompute summed over every repeat (the figures above "
                 "are the fastest repeat's)"},
        {"propagate", {{"bets_lost", propagate_all.bets_lost},
                       {"rollbacks", propagate_all.rollbacks},
                       {"bodies_resolved", propagate_all.bodies_resolved},
                       {"bodies_replayed", propagate_all.bodies_replayed}}},
        {"recompute", {{"bets_lost", recompute_all.bets_lost},
                       {"rollbacks", recompute_all.rollbacks},
                       {"bodies_resolved", recompute_all.bodies_resolved}}},
        {"bodies_resolved_propagate_over_recompute",
         recompute_all.bodies_resolved ? nlohmann::json(static_cast<double>(propagate_all.bodies_resolved) /
                                                        static_cast<double>(recompute_all.bodies_resolved))
                                       : nlohmann::json(nullptr)},
        {"bodies_resolved_per_lost_bet_propagate_over_recompute",
         per_bet_recompute_all > 0
             ? nlohmann::json(bodies_resolved_per_lost_bet(propagate_all) / per_bet_recompute_all)
             : nlohmann::json(nullptr)}}},
      {"one_territory_state_hash", hash_hex(one.best.state_hash)},
      {"stock_state_hash", hash_hex(stock.best.state_hash)},
      {"state_hashes_equal", r.hashes_equal},
  };
}

}  // namespace soda
