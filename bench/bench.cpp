#include "soda/bench/bench.h"

#include <algorithm>
#include <stdexcept>

#include <spdlog/spdlog.h>

namespace soda {

BenchResult bench_scene(const Scene& scene, const BenchConfig& config) {
  if (config.repeat < 1) throw std::invalid_argument("--repeat must be >= 1");
  RunConfig baseline_config = config.run;
  baseline_config.world = WorldKind::Stock;
  baseline_config.territories = 1;
  baseline_config.shuffle_seed = 0;
  BenchResult out;
  for (int i = 0; i < config.repeat; ++i) {
    auto run_baseline = [&] {
      RunResult r = run_scene(scene, baseline_config);
      out.baseline_walls.push_back(r.wall_seconds);
      if (out.baseline_walls.size() == 1 || r.wall_seconds < out.baseline.wall_seconds) out.baseline = r;
    };
    auto run_tested = [&] {
      RunResult r = run_scene(scene, config.run);
      out.run_walls.push_back(r.wall_seconds);
      if (out.run_walls.size() == 1 || r.wall_seconds < out.run.wall_seconds) out.run = r;
    };
    if (i % 2 == 0) {
      run_baseline();
      run_tested();
    } else {
      run_tested();
      run_baseline();
    }
    spdlog::info("repeat {}/{}: baseline {:.3f} s, {} {:.3f} s", i + 1, config.repeat,
                 out.baseline_walls.back(), world_kind_name(config.run.world), out.run_walls.back());
  }
  out.ratio_vs_baseline = out.baseline.wall_seconds > 0 ? out.run.wall_seconds / out.baseline.wall_seconds : 0.0;
  return out;
}

}  // namespace soda
