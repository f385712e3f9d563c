// What a run is built from: the order its bodies are inserted in and the
// grid its partition is cut on (run.h).
#include <numeric>
#include <random>

#include "soda/runtime/run.h"

namespace soda {

std::vector<std::size_t> insertion_order(std::size_t body_count, std::uint64_t shuffle_seed) {
  std::vector<std::size_t> order(body_count);
  std::iota(order.begin(), order.end(), std::size_t{0});
  if (shuffle_seed == 0) return order;
  // Fisher-Yates with an explicit bounded draw: std::shuffle's use of the
  // engine is implementation-defined, this is the same everywhere.
  std::mt19937_64 rng(shuffle_seed);
  for (std::size_t i = body_count; i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(rng() % i);
    std::swap(order[i - 1], order[j]);
  }
  return order;
}

GridOptions grid_options(const RunConfig& config) {
  GridOptions grid;
  grid.cell_size = config.cell_size;
  if (!config.runtime.balance.triangle_cost) grid.triangle_weight = 0;
  return grid;
}

Scene in_insertion_order(const Scene& scene, std::uint64_t shuffle_seed) {
  Scene out = scene;
  if (shuffle_seed == 0) return out;
  const std::vector<std::size_t> order = insertion_order(scene.bodies.size(), shuffle_seed);
  for (std::size_t i = 0; i < order.size(); ++i) out.bodies[i] = scene.bodies[order[i]];
  return out;
}

}  // namespace soda
