// Embedding SODA: a Simulation of falling-cubes on 4 worlds runs in the
// background; a render thread reads the whole scene at 60 Hz of simulated
// time and prints each frame's centre of mass and body count; after 5
// simulated seconds the run stops and its state hash is checked against
// one CanonicalWorld run of the same steps.
// Usage: embed [N] [SECONDS]   (N cubes, default 500; default 5 s)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <thread>
#include <unordered_map>

#include "soda/runtime/simulation.h"
#include "soda/worlds/canonical_world.h"

int main(int argc, char** argv) {
  try {
    const int n = argc > 1 ? std::atoi(argv[1]) : 500;
    const double seconds = argc > 2 ? std::atof(argv[2]) : 5.0;
    const soda::Scene scene = soda::make_scene("falling-cubes", {n, 1});
    std::unordered_map<soda::BodyId, double> mass;
    for (const soda::Body& b : scene.bodies) mass[b.id] = b.mass;

    soda::Simulation sim(scene, {.territories = 4});
    soda::SceneReader reader = sim.add_reader();  // before start: it sees step 0 on

    // The render thread: one frame per 1/60 s of simulated time; read_at
    // waits until every world has published that time.
    std::exception_ptr render_error;
    std::thread render([&] {
      try {
        const int frames = static_cast<int>(std::lround(seconds * 60.0));
        for (int k = 0; k <= frames; ++k) {
          const std::optional<soda::SceneFrame> frame = reader.read_at(k / 60.0);
          if (!frame) break;  // stopped before that time
          double m = 0, c[3] = {0, 0, 0};
          for (const soda::ScenePose& p : frame->poses) {
            const double w = mass[p.id];
            m += w;
            for (int i = 0; i < 3; ++i) c[i] += w * static_cast<double>(p.position[i]);
          }
          std::printf("frame %3d  t %.3f s  step %3lld  %zu bodies  centre of mass (%.4f, %.4f, %.4f)\n", k, frame->time,
                      static_cast<long long>(frame->step), frame->poses.size(), c[0] / m, c[1] / m, c[2] / m);
        }
      } catch (...) {
        render_error = std::current_exception();
      }
    });

    sim.start(seconds);       // the worlds run freely up to `seconds`
    sim.advance_to(seconds);  // this thread waits until every world got there
    render.join();
    sim.stop();
    if (render_error) std::rethrow_exception(render_error);

    const std::int64_t steps = sim.steps_done();
    const std::uint64_t hash = sim.state_hash();
    soda::CanonicalWorld reference(scene);
    for (std::int64_t s = 0; s < steps; ++s) reference.step();
    const std::uint64_t expected = reference.state_hash();
    std::printf("%d worlds (%s, %d threads), %lld steps: state_hash %s; one CanonicalWorld: %s -> %s\n",
                sim.world_count(), soda::schedule_name(sim.schedule()), sim.thread_count(),
                static_cast<long long>(steps), soda::hash_hex(hash).c_str(), soda::hash_hex(expected).c_str(),
                hash == expected ? "identical" : "DIFFERENT");
    return hash == expected ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "embed: %s\n", e.what());
    return 1;
  }
}
