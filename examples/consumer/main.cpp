// A program outside SODA's tree, built against the installed package
// (examples/consumer/CMakeLists.txt): it builds a scene, runs it on two
// territories (two Bullet worlds on two threads) and on one, and prints both
// state hashes and whether they are equal (they must be: exit code 1 if not).
// Usage: consumer [N] [STEPS]   (N falling cubes, default 300; default 120 steps)
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "soda/runtime/simulation.h"

namespace {

// The whole scene's state hash after `steps` scene steps on `territories` worlds.
std::uint64_t run(const soda::Scene& scene, int territories, std::int64_t steps) {
  soda::Simulation sim(scene, {.territories = territories});
  sim.advance_to(sim.time_of(steps));  // runs every world to that step and parks it there
  return sim.state_hash();
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const int n = argc > 1 ? std::atoi(argv[1]) : 300;
    const std::int64_t steps = argc > 2 ? std::atoll(argv[2]) : 120;
    const soda::Scene scene = soda::make_scene("falling-cubes", {.n = n});
    const std::uint64_t two = run(scene, 2, steps);
    const std::uint64_t one = run(scene, 1, steps);
    std::printf("falling-cubes %d, %lld steps, btScalar of %zu bytes: 2 territories %s, 1 territory %s: %s\n", n,
                static_cast<long long>(steps), sizeof(btScalar), soda::hash_hex(two).c_str(),
                soda::hash_hex(one).c_str(), two == one ? "equal" : "DIFFERENT");
    return two == one ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 2;
  }
}
