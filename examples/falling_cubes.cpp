// The smallest embedding of SODA: generate the falling-cubes scene, run it,
// print the state hash. Usage: falling_cubes [N] [STEPS] [TERRITORIES]
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "soda/runtime/run.h"
#include "soda/scene/registry.h"

int main(int argc, char** argv) {
  try {
    soda::SceneParams params;
    params.n = argc > 1 ? std::atoi(argv[1]) : 500;
    params.seed = 1;
    const soda::Scene scene = soda::make_scene("falling-cubes", params);
    soda::RunConfig config;
    config.steps = argc > 2 ? std::atoi(argv[2]) : 300;
    config.territories = argc > 3 ? std::atoi(argv[3]) : 1;  // > 1: a world per territory, each on its thread
    const soda::RunResult r = soda::run_scene(scene, config);
    std::printf("%zu bodies, %d steps, %.3f s, %zu asleep, state_hash %016llx\n", r.bodies, r.steps,
                r.wall_seconds, r.sleeping_bodies, static_cast<unsigned long long>(r.state_hash));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "falling_cubes: %s\n", e.what());
    return 1;
  }
}
