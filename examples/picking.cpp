// Picking while the simulation runs (docs/embedding.md, "Queries"): falling
// cubes on 2 territories run freely in the background; a picking thread
// orbits a camera around the scene at 60 Hz of simulated time and casts a
// ray from it through the scene's centre at every frame, and a sphere sweep
// every second — the answers come from each step's committed frame. The
// same rays against one world stepped by hand give the same picks, bit for
// bit, and the run ends on the one-world state hash.
// Usage: picking [N] [SECONDS]   (N cubes, default 500; default 3 s)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <thread>
#include <vector>

#include "soda/runtime/simulation.h"

namespace {

struct Pick {
  std::int64_t step = -1;
  soda::BodyId id = 0;
  double fraction = 1;
};

// The camera at frame k: on a circle of radius 40 m, 15 m up, looking at
// the centre of the scene.
void camera(int k, soda::Vec3& eye, soda::Vec3& target) {
  const double angle = 0.02 * k;
  eye = soda::Vec3(40 * std::cos(angle), 15, 40 * std::sin(angle));
  target = soda::Vec3(0, 2, 0);
}

std::vector<Pick> pick_all(soda::SceneQuery& query, int frames, const std::function<void(int)>& before) {
  std::vector<Pick> picks;
  for (int k = 0; k <= frames; ++k) {
    if (before) before(k);
    soda::Vec3 eye, target;
    camera(k, eye, target);
    const auto hit = query.ray_cast(k / 60.0, eye, eye + 2.0 * (target - eye));
    if (!hit) break;  // the run was stopped
    Pick p;
    p.step = hit->step;
    if (!hit->items.empty()) p.id = hit->items[0].id, p.fraction = hit->items[0].fraction;
    picks.push_back(p);
    if (k % 60 == 0) {
      const auto swept = query.sweep(k / 60.0, soda::Shape::sphere(1.0), eye, target);
      std::printf("t = %.2f s (step %lld): picked body %u at %.3f of the ray; a 1 m sphere thrown from the camera "
                  "touches %zu bodies on its way\n",
                  k / 60.0, static_cast<long long>(p.step), p.id, p.fraction, swept ? swept->items.size() : 0);
    }
  }
  return picks;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const int n = argc > 1 ? std::atoi(argv[1]) : 500;
    const double seconds = argc > 2 ? std::atof(argv[2]) : 3.0;
    const int frames = static_cast<int>(std::lround(seconds * 60));
    const soda::Scene scene = soda::make_scene("falling-cubes", {n, 1});

    soda::Simulation sim(scene, {.territories = 2});
    soda::SceneQuery query = sim.add_query();  // before start: it sees step 0
    sim.start(seconds);
    std::vector<Pick> picks;
    std::exception_ptr error;
    std::thread picking([&] {
      try {
        picks = pick_all(query, frames, {});
      } catch (...) {
        error = std::current_exception();
      }
    });
    picking.join();
    if (error) std::rethrow_exception(error);
    sim.advance_to(seconds);
    const std::uint64_t hash = sim.state_hash();

    // One world, stepped by hand to each frame, asked the same.
    soda::Simulation one(scene, {.threads = 1});
    soda::SceneQuery one_query = one.add_query();
    const std::vector<Pick> expected = pick_all(one_query, frames, [&](int k) { one.advance_to(k / 60.0); });
    one.advance_to(seconds);
    bool same = picks.size() == expected.size();
    for (std::size_t i = 0; same && i < picks.size(); ++i)
      same = picks[i].step == expected[i].step && picks[i].id == expected[i].id &&
             std::memcmp(&picks[i].fraction, &expected[i].fraction, sizeof(double)) == 0;
    const bool hash_ok = hash == one.state_hash();
    std::printf("%zu picks, %s the one world's; state hash %016llx, one world %016llx: %s\n", picks.size(),
                same ? "every one equal to" : "NOT all equal to", static_cast<unsigned long long>(hash),
                static_cast<unsigned long long>(one.state_hash()), hash_ok ? "equal" : "DIFFERENT");
    return same && hash_ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "picking: %s\n", e.what());
    return 1;
  }
}
