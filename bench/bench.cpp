#include "soda/bench/bench.h"

#include <algorithm>
#include <stdexcept>

#include "soda/runtime/process_group.h"

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

namespace soda {

namespace {

// One interleaved rotation of (baseline, one territory, run) with the
// sleeping setting of `run_config`.
BenchSet bench_set(const Scene& scene, const RunConfig& run_config, int repeat) {
  RunConfig baseline_config = run_config;
  baseline_config.world = WorldKind::Stock;
  baseline_config.territories = 1;
  baseline_config.shuffle_seed = 0;
  baseline_config.runtime.solver_threads = 1;  // stock Bullet has no coloured solve
  baseline_config.solver_defaults = SolverDefaults::Soda;  // the stock world has its own
  baseline_config.group = nullptr;
  RunConfig one_config = run_config;
  one_config.territories = 1;
  one_config.group = nullptr;
  const bool partitioned = run_config.territories > 1;
  // Over ranks (mpirun) the tested run is every rank's, collective; the
  // baseline and the one-territory run are rank 0's alone, while the other
  // ranks wait for it in the next tested run's set-up.
  const bool rank0 = !run_config.group || run_config.group->rank() == 0;
  const char* sleeping = run_config.sleeping ? "sleeping on" : "sleeping off";
  BenchSet out;
  auto keep_fastest = [](RunResult r, RunResult& best, std::vector<double>& walls) {
    walls.push_back(r.wall_seconds);
    if (walls.size() == 1 || r.wall_seconds < best.wall_seconds) best = std::move(r);
  };
  for (int i = 0; i < repeat; ++i) {
    auto run_baseline = [&] {
      if (rank0) keep_fastest(run_scene(scene, baseline_config), out.baseline, out.baseline_walls);
    };
    auto run_tested = [&] { keep_fastest(run_scene(scene, run_config), out.run, out.run_walls); };
    auto run_one = [&] {
      if (partitioned && rank0)
        keep_fastest(run_scene(scene, one_config), out.one_territory, out.one_territory_walls);
    };
    if (i % 2 == 0) {
      run_baseline();
      run_one();
      run_tested();
    } else {
      run_tested();
      run_one();
      run_baseline();
    }
    if (!rank0) continue;
    spdlog::info("{}, repeat {}/{}: baseline {:.3f} s, {} {:.3f} s{}", sleeping, i + 1, repeat,
                 out.baseline_walls.back(), world_kind_name(run_config.world), out.run_walls.back(),
                 partitioned ? fmt::format(" ({} territories; one territory {:.3f} s)", run_config.territories,
                                           out.one_territory_walls.back())
                             : std::string());
  }
  out.ratio_vs_baseline = out.run.wall_seconds > 0 ? out.baseline.wall_seconds / out.run.wall_seconds : 0.0;
  if (partitioned && out.run.wall_seconds > 0)
    out.speedup_vs_one_territory = out.one_territory.wall_seconds / out.run.wall_seconds;
  return out;
}

bool hashes_agree(const BenchSet& s) {
  return s.run.territories <= 1 || s.run.state_hash == s.one_territory.state_hash;
}

}  // namespace

BenchResult bench_scene(const Scene& scene, const BenchConfig& config) {
  if (config.repeat < 1) throw std::invalid_argument("--repeat must be >= 1");
  RunConfig on = config.run;
  on.sleeping = true;
  BenchResult out;
  static_cast<BenchSet&>(out) = bench_set(scene, on, config.repeat);
  if (config.awake_pair) {
    RunConfig off = config.run;
    off.sleeping = false;
    out.awake = bench_set(scene, off, config.repeat);
    out.has_awake = true;
  }
  return out;
}

int bench_exit_code(const BenchResult& b) {
  const bool exact = hashes_agree(b) && (!b.has_awake || hashes_agree(b.awake));
  return exact ? 0 : 1;
}

double slowest_world_cpu_seconds(const std::vector<WorldMetrics>& worlds) {
  std::size_t steps = 0;
  for (const WorldMetrics& w : worlds) steps = std::max(steps, w.cpu_step_ms.size());
  double total_ms = 0;
  for (std::size_t s = 0; s < steps; ++s) {
    double slowest = 0;
    for (const WorldMetrics& w : worlds)
      if (s < w.cpu_step_ms.size()) slowest = std::max(slowest, w.cpu_step_ms[s]);
    total_ms += slowest;
  }
  return total_ms * 1e-3;
}

double bodies_resolved_per_rollback(const WorldMetrics& m) {
  return m.rollbacks > 0 ? static_cast<double>(m.bodies_resolved) / static_cast<double>(m.rollbacks) : 0.0;
}

double bodies_resolved_per_lost_bet(const WorldMetrics& m) {
  return m.bets_lost > 0 ? static_cast<double>(m.bodies_resolved) / static_cast<double>(m.bets_lost) : 0.0;
}

}  // namespace soda
