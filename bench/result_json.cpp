#include "soda/bench/result_json.h"

#include <fstream>
#include <iostream>
#include <stdexcept>

#include "soda/worlds/body_state.h"

namespace soda {
namespace {

nlohmann::json step_time_json(const StepTimeStats& s) {
  return {{"mean", s.mean_ms}, {"median", s.median_ms}, {"p95", s.p95_ms}, {"min", s.min_ms}, {"max", s.max_ms}};
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
      {"threads", d.config.threads == 0 ? r.territories : d.config.threads},
      {"shuffle_seed", d.config.shuffle_seed},
      {"dt", st.dt},
      {"substeps", st.substeps},
      {"iterations", st.iterations},
      {"steps", r.steps},
      {"bodies", r.bodies},
      {"dynamic_bodies", r.dynamic_bodies},
      {"sleeping_bodies", r.sleeping_bodies},
      {"state_hash", hash_hex(r.state_hash)},
      {"wall_seconds", r.wall_seconds},
      {"cpu_seconds", r.cpu_seconds},
      {"steps_per_second", r.wall_seconds > 0 ? r.steps / r.wall_seconds : 0.0},
      {"real_time_factor", r.wall_seconds > 0 ? simulated / r.wall_seconds : 0.0},
      {"step_ms", step_time_json(r.step_time)},
  };
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
