// Shared helpers of the worlds/ suites: scenes, insertion orders, runs.
#pragma once

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "soda/scene/registry.h"
#include "soda/worlds/body_state.h"

namespace soda::test {

// A few hundred bodies, 600 steps: big enough for heaps, sleeping and
// stale pairs; small enough for the whole suite to stay well under 2 minutes.
inline constexpr int kBodies = 300;
inline constexpr int kSteps = 600;

inline Scene scene(const std::string& name, int n = kBodies, std::uint64_t seed = 1) {
  return make_scene(name, SceneParams{n, seed, false});
}

inline std::vector<std::size_t> identity_order(std::size_t n) {
  std::vector<std::size_t> o(n);
  std::iota(o.begin(), o.end(), std::size_t{0});
  return o;
}
inline std::vector<std::size_t> reversed_order(std::size_t n) {
  auto o = identity_order(n);
  std::reverse(o.begin(), o.end());
  return o;
}
inline std::vector<std::size_t> shuffled_order(std::size_t n, std::uint32_t seed) {
  auto o = identity_order(n);
  std::mt19937 rng(seed);
  std::shuffle(o.begin(), o.end(), rng);
  return o;
}

template <class World>
void run(World& world, int steps) {
  for (int i = 0; i < steps; ++i) world.step();
}

}  // namespace soda::test
