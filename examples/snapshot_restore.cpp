// Snapshots of a running Simulation (docs/embedding.md, "Snapshots"): a
// robot's planner asks "what if?". A pile of boxes runs on 2 territories
// to t = 2 s and is snapshotted; the run goes on to 4 s. The snapshot is
// restored on 4 territories with speculation, a push is tried on it and
// thrown away, and it is restored again on 8 territories and run to 4 s
// untouched: its hash equals the uninterrupted run's.
// Usage: snapshot_restore [N]   (N boxes, default 300)
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "soda/runtime/simulation.h"

int main(int argc, char** argv) {
  try {
    const int n = argc > 1 ? std::atoi(argv[1]) : 300;
    const soda::Scene scene = soda::make_scene("cube-pile", {n, 1});

    soda::Simulation sim(scene, {.territories = 2});
    sim.advance_to(2.0);
    const soda::SimulationSnapshot at_two = sim.snapshot();  // bodies, contacts, queued inputs
    sim.advance_to(4.0);
    const std::uint64_t uninterrupted = sim.state_hash();
    std::printf("snapshot at step %lld: %zu bodies, %zu contact manifolds\n",
                static_cast<long long>(at_two.state.steps_done), at_two.state.bodies.size(),
                at_two.state.manifolds.size());

    {  // What if the first box were pushed? (thrown away afterwards)
      soda::SimulationConfig what_if{.territories = 4};
      what_if.runtime.anticipation = 8;
      soda::Simulation trial(at_two, what_if);
      trial.apply_impulse(2.0, scene.bodies[1].id, soda::Vec3(0, 30, 0));
      trial.advance_to(4.0);
      std::printf("with the push: hash %016llx\n", static_cast<unsigned long long>(trial.state_hash()));
    }

    soda::Simulation resumed(at_two, {.territories = 8});
    resumed.advance_to(4.0);
    const std::uint64_t h = resumed.state_hash();
    std::printf("uninterrupted (2 territories) %016llx, restored at 2 s on 8 territories %016llx: %s\n",
                static_cast<unsigned long long>(uninterrupted), static_cast<unsigned long long>(h),
                h == uninterrupted ? "equal" : "DIFFERENT");
    return h == uninterrupted ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "snapshot_restore: %s\n", e.what());
    return 1;
  }
}
