#include "soda/bench/result_json.h"

#include <cctype>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "soda/worlds/body_state.h"

namespace soda {
namespace {

nlohmann::json step_time_json(const StepTimeStats& s) {
  return {{"mean", s.mean_ms}, {"median", s.median_ms}, {"p95", s.p95_ms}, {"min", s.min_ms}, {"max", s.max_ms}};
}

// Honest baselines: the bodies asleep in every run, the
// runs with sleeping off, and what each ratio contains.
nlohmann::json bench_set_json(const BenchSet& s) {
  nlohmann::json j = {{"wall_seconds", s.run.wall_seconds},
                      {"wall_seconds_all", s.run_walls},
                      {"cpu_seconds", s.run.cpu_seconds},
                      {"state_hash", hash_hex(s.run.state_hash)},
                      {"sleeping_bodies", s.run.sleeping_bodies},
                      {"baseline_wall_seconds", s.baseline.wall_seconds},
                      {"baseline_cpu_seconds", s.baseline.cpu_seconds},
                      {"baseline_wall_seconds_all", s.baseline_walls},
                      {"baseline_state_hash", hash_hex(s.baseline.state_hash)},
                      {"baseline_sleeping_bodies", s.baseline.sleeping_bodies},
                      {"ratio_vs_baseline", s.ratio_vs_baseline}};
  if (s.run.territories > 1) {
    j["one_territory_wall_seconds"] = s.one_territory.wall_seconds;
    j["one_territory_wall_seconds_all"] = s.one_territory_walls;
    j["one_territory_state_hash"] = hash_hex(s.one_territory.state_hash);
    j["one_territory_cpu_seconds"] = s.one_territory.cpu_seconds;
    j["one_territory_sleeping_bodies"] = s.one_territory.sleeping_bodies;
    j["state_hash_equals_one_territory"] = s.one_territory.state_hash == s.run.state_hash;
    j["speedup_vs_one_territory"] = s.speedup_vs_one_territory;
  }
  return j;
}

nlohmann::json honest_baseline_json(const BenchResult& b) {
  nlohmann::json j;
  j["baseline_sleeping_bodies"] = b.baseline.sleeping_bodies;
  j["baseline_cpu_seconds"] = b.baseline.cpu_seconds;
  if (b.run.territories > 1) j["one_territory_sleeping_bodies"] = b.one_territory.sleeping_bodies;
  j["ratio_vs_baseline_note"] =
      "stock wall / wall (> 1: faster than stock), sleeping on in both (Bullet's default): includes the bodies the canonical world puts to "
      "sleep sooner (its islands come from contacts, stock Bullet's from broadphase pairs); see sleeping_bodies "
      "and baseline_sleeping_bodies";
  if (b.has_awake) {
    j["ratio_vs_baseline_awake"] = b.awake.ratio_vs_baseline;
    j["ratio_vs_baseline_awake_note"] =
        "stock wall / wall (> 1: faster than stock) of a second pair of runs with sleeping off in every world: no body sleeps on either "
        "side, the step's own cost";
    if (b.run.territories > 1)
      j["state_hash_equals_one_territory_awake"] = b.awake.one_territory.state_hash == b.awake.run.state_hash;
    j["awake"] = bench_set_json(b.awake);
  }
  j["exit_code"] = bench_exit_code(b);
  return j;
}

}  // namespace

nlohmann::json stages_json(const WorldMetrics& m) {
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t i = 0; i < kStageCount; ++i) {
    const StageCost& c = m.stages[i];
    j[stage_name(static_cast<Stage>(i))] = {{"cpu_seconds", c.cpu_seconds},
                                            {"wait_seconds", c.wait_seconds},
                                            {"items", c.items},
                                            {"messages", c.messages},
                                            {"bytes", c.bytes}};
  }
  return j;
}

nlohmann::json traffic_json(const WorldMetrics& m) {
  const auto kind_name = [](MessageKind kind) {
    std::string name = message_kind_name(kind);
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return name;
  };
  const MessageTraffic& t = m.traffic;
  nlohmann::json flows = nlohmann::json::array();
  for (const MessageFlow& f : t.flows)
    flows.push_back({{"to", f.to},
                     {"kind", kind_name(f.kind)},
                     {"messages", f.messages},
                     {"bytes", f.bytes},
                     {"steps", f.steps},
                     {"max_per_step", f.max_per_step}});
  nlohmann::json rounds = nlohmann::json::object();
  for (std::size_t k = 0; k < kMessageKindCount; ++k) rounds[kind_name(static_cast<MessageKind>(k + 1))] = t.rounds[k];
  return {{"internal_steps", m.steps},
          {"flows", std::move(flows)},
          {"rounds", std::move(rounds)},
          {"island_depth_sum", t.island_depth_sum},
          {"island_depth_max", t.island_depth_max}};
}

nlohmann::json speculation_json(const WorldMetrics& m) {
  return {{"bets", m.bets},
          {"bets_lost", m.bets_lost},
          {"rollbacks", m.rollbacks},
          {"steps_rolled_back", m.steps_rolled_back},
          {"steps_rejoined", m.steps_rejoined},
          {"bodies_resolved", m.bodies_resolved},
          {"bodies_replayed", m.bodies_replayed},
          {"bodies_resolved_per_rollback", bodies_resolved_per_rollback(m)},
          {"bodies_resolved_per_lost_bet", bodies_resolved_per_lost_bet(m)},
          {"rollback_cpu_seconds", m.rollback_cpu_seconds},
          {"rollback_cpu_share", m.cpu_seconds > 0 ? m.rollback_cpu_seconds / m.cpu_seconds : 0.0},
          {"lead_max", m.lead_max},
          {"lead_mean", m.lead_mean},
          {"kept_states_max", m.kept_states_max}};
}

namespace {

// Load balancing (docs/loadbalance.md): the options, the totals and one row
// per balance step.
nlohmann::json balance_json(const BalanceOptions& o, const std::vector<BalanceRecord>& log) {
  const BalanceTotals t = balance_totals(log);
  nlohmann::json steps = nlohmann::json::array();
  for (const BalanceRecord& r : log)
    steps.push_back({{"step", r.step},
                     {"cells_moved", r.cells_moved},
                     {"bodies_moved", r.bodies_moved},
                     {"gather_cpu_seconds", r.gather_cpu_seconds},
                     {"decide_cpu_seconds", r.decide_cpu_seconds},
                     {"apply_cpu_seconds", r.apply_cpu_seconds},
                     {"wall_seconds", r.wall_seconds},
                     {"cells_owned", r.cells_owned},
                     {"cells_out", r.cells_out},
                     {"cells_in", r.cells_in},
                     {"bodies_out", r.bodies_out},
                     {"bodies_in", r.bodies_in}});
  return {{"policy", o.policy},
          {"period", o.period},
          {"seed", o.seed},
          {"smoothing", o.smoothing},
          {"overload", o.overload},
          {"underload", o.underload},
          {"max_cells_per_move", o.max_cells_per_move},
          {"balance_steps", t.balance_steps},
          {"cells_moved", t.cells_moved},
          {"bodies_moved", t.bodies_moved},
          {"cpu_seconds", t.cpu_seconds()},
          {"gather_cpu_seconds", t.gather_cpu_seconds},
          {"decide_cpu_seconds", t.decide_cpu_seconds},
          {"apply_cpu_seconds", t.apply_cpu_seconds},
          {"wall_seconds", t.wall_seconds},
          {"steps", steps}};
}

}  // namespace

nlohmann::json run_json(const RunDescription& d, const RunResult& r) {
  const SceneSettings& st = d.resolved->settings;
  const double simulated = r.steps * st.dt;
  nlohmann::json j = {
      {"scene", d.scene},
      {"params", {{"n", d.params.n}, {"seed", d.params.seed}, {"random_scale", d.params.random_scale}}},
      {"seed", d.params.seed},
      {"world", world_kind_name(r.world)},
      {"precision", kPrecisionName},
      {"territories", r.territories},
      {"partition", d.config.partition},
      {"cell_size", d.config.cell_size ? nlohmann::json(*d.config.cell_size) : nlohmann::json(nullptr)},
      {"threads", d.config.threads == 0 ? r.territories : d.config.threads},
      {"shuffle_seed", d.config.shuffle_seed},
      {"dt", st.dt},
      {"parking", d.config.runtime.parking},
      {"substeps", st.substeps},
      {"iterations", st.iterations},
      {"steps", r.steps},
      {"bodies", r.bodies},
      {"dynamic_bodies", r.dynamic_bodies},
      {"sleeping_bodies", r.sleeping_bodies},
      {"state_hash", hash_hex(r.state_hash)},
      {"wall_seconds", r.wall_seconds},
      {"cpu_seconds", r.cpu_seconds},
      {"process_cpu_seconds", r.process_cpu_seconds},
      {"setup_seconds", r.setup_seconds},
      {"setup_cpu_seconds", r.setup_cpu_seconds},
      {"teardown_seconds", r.teardown_seconds},
      {"teardown_cpu_seconds", r.teardown_cpu_seconds},
      {"memory_estimate_bytes", r.memory_estimate_bytes},
      {"level_geometry_bytes", r.level_geometry_bytes},
      {"migrations", r.migrations},
      {"bodies_at_start", r.bodies_at_start},
      {"bodies_at_end", r.bodies_at_end},
      {"contact_pairs_at_start", r.contact_pairs_at_start},
      {"contact_pairs_at_end", r.contact_pairs_at_end},
      {"steps_per_second", r.wall_seconds > 0 ? r.steps / r.wall_seconds : 0.0},
      {"real_time_factor", r.wall_seconds > 0 ? simulated / r.wall_seconds : 0.0},
      {"step_ms", step_time_json(r.step_time)},
      {"watchdog", watchdog_response_name(d.config.runtime.watchdog.response)},
      {"healed_steps", r.healed_steps},
      {"sync_test", d.config.sync_test},
      {"sync_rollbacks", r.sync_rollbacks},
      {"anticipation", d.config.runtime.anticipation},
      {"rollback", rollback_name(d.config.runtime.rollback)},
      {"checkpoint_every", d.config.runtime.checkpoint_every},
      {"eager_bets", d.config.runtime.eager_bets},
      {"balance", balance_json(d.config.runtime.balance, r.balance_log)},
  };
  if (!d.config.record_path.empty()) {  // soda run --record: the replay file's cost (docs/replay-format.md)
    const double per_kbody_second =
        simulated > 0 && r.dynamic_bodies ? static_cast<double>(r.record_bytes) / (r.dynamic_bodies / 1000.0) / simulated
                                          : 0.0;
    j["record"] = {{"path", d.config.record_path},
                   {"frames", r.record_frames},
                   {"bytes", r.record_bytes},
                   {"cpu_seconds", r.record_cpu_seconds},
                   {"bytes_per_1000_bodies_per_simulated_second", per_kbody_second}};
  }
  if (r.territories > 1) {
    j["schedule"] = r.schedule;
    j["threads"] = r.threads;
    j["messages"] = r.messages;
    j["reach_speed"] = d.config.runtime.reach_speed;
    j["reach_cells"] = r.reach_cells;
    j["message_bytes"] = r.message_bytes;
    j["slowest_world_cpu_seconds"] = slowest_world_cpu_seconds(r.world_metrics);
    if (!r.ranks.empty()) {  // under mpirun (docs/mpi.md)
      nlohmann::json ranks = nlohmann::json::array();
      for (const RankTraffic& t : r.ranks)
        ranks.push_back({{"rank", t.rank},
                         {"worlds", t.worlds},
                         {"cpu_seconds", t.cpu_seconds},
                         {"blocked_seconds", t.blocked_seconds},
                         {"messages", t.messages},
                         {"bytes", t.bytes},
                         {"messages_to_other_ranks", t.messages_out},
                         {"bytes_to_other_ranks", t.bytes_out},
                         {"messages_from_other_ranks", t.messages_in},
                         {"bytes_from_other_ranks", t.bytes_in},
                         {"communication_loop_seconds", t.pump_seconds},
                         {"communication_loop_idle_seconds", t.pump_idle_seconds},
                         {"gvt_rounds", t.gvt_rounds},
                         {"bullet_objects", t.bullet_objects},
                         {"peak_rss_bytes", t.peak_rss_bytes}});
      j["ranks"] = std::move(ranks);
    }
    nlohmann::json worlds = nlohmann::json::array();
    for (const WorldMetrics& m : r.world_metrics) {
      // Every counter under its field name (for_each_counter), then what
      // is derived from them.
      nlohmann::json row = {{"world", m.world},
                            {"cpu_step_mean_ms", m.cpu_step_mean_ms},
                            {"cpu_step_max_ms", m.cpu_step_max_ms},
                            {"merged_island_worlds_mean",
                             m.merged_islands ? static_cast<double>(m.merged_island_worlds_sum) /
                                                    static_cast<double>(m.merged_islands)
                                              : 0.0}};
      for_each_counter(m, [&](const char* name, const auto& value, CounterFold) { row[name] = value; });
      row.update(speculation_json(m));
      row["stages"] = stages_json(m);
      row["traffic"] = traffic_json(m);
      worlds.push_back(std::move(row));
    }
    j["worlds"] = std::move(worlds);
    j["speculation"] = speculation_json(total_metrics(r.world_metrics));
  }
  return j;
}

nlohmann::json bench_json(const RunDescription& d, const BenchResult& b) {
  nlohmann::json j = run_json(d, b.run);
  j["repeat"] = b.run_walls.size();
  j["wall_seconds_all"] = b.run_walls;
  j["baseline"] = "stock btDiscreteDynamicsWorld, one world, same scene, same process";
  j["baseline_wall_seconds"] = b.baseline.wall_seconds;
  j["baseline_wall_seconds_all"] = b.baseline_walls;
  j["baseline_state_hash"] = hash_hex(b.baseline.state_hash);
  j["baseline_step_ms"] = step_time_json(b.baseline.step_time);
  j["ratio_vs_baseline"] = b.ratio_vs_baseline;
  if (b.run.territories > 1) {
    j["one_territory_wall_seconds"] = b.one_territory.wall_seconds;
    j["one_territory_wall_seconds_all"] = b.one_territory_walls;
    j["one_territory_cpu_seconds"] = b.one_territory.cpu_seconds;
    j["one_territory_state_hash"] = hash_hex(b.one_territory.state_hash);
    j["state_hash_equals_one_territory"] = b.one_territory.state_hash == b.run.state_hash;
    j["speedup_vs_one_territory"] = b.speedup_vs_one_territory;
    const double slowest = slowest_world_cpu_seconds(b.run.world_metrics);
    j["projected_speedup"] = slowest > 0 ? b.one_territory.cpu_seconds / slowest : 0.0;
    j["projected_speedup_note"] =
        "projection: one-territory CPU seconds / sum over steps of the slowest world's CPU time "
        "(the thesis' measure); what the run would reach with one core per world";
  }
  j.update(honest_baseline_json(b));
  return j;
}

void write_json(const nlohmann::json& j, const std::string& path) {
  const std::string text = j.dump(2) + "\n";
  if (path == "-") {
    std::cout << text << std::flush;
    return;
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << text;
  out.close();
  if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace soda
