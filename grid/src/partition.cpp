// make_partition (the spec dispatcher), the k-means partition, and the
// helpers every method shares.
#include "soda/grid/partition.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <tuple>

#include "partition_detail.h"
#include "soda/grid/cell_triangles.h"
#include "soda/grid/kmeans.h"
#include "soda/grid/map_file.h"

namespace soda {
namespace detail {

std::vector<Vec3> dynamic_positions(const Scene& scene) {
  std::vector<const Body*> bodies;
  for (const Body& b : scene.bodies)
    if (!b.is_static) bodies.push_back(&b);
  std::sort(bodies.begin(), bodies.end(),
            [](const Body* a, const Body* b) { return a->id < b->id; });
  std::vector<Vec3> positions;
  positions.reserve(bodies.size());
  for (const Body* b : bodies) positions.push_back(b->position);
  return positions;
}

std::vector<std::int64_t> dynamic_weights(const Scene& scene, const UniformGrid& grid, const CellBox& box,
                                          double triangle_weight) {
  if (!std::isfinite(triangle_weight) || triangle_weight < 0)
    throw GridError("triangle weight " + std::to_string(triangle_weight) + " must be finite and >= 0");
  const std::vector<Vec3> positions = dynamic_positions(scene);
  std::vector<std::int64_t> weights(positions.size(), kBodyWeight);
  if (triangle_weight == 0 || !has_level_geometry(scene.bodies)) return weights;
  const std::vector<std::int32_t> triangles = cell_triangles(scene.bodies, grid, box);
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const double t = triangles[box.index(box.clamp(grid.cell_of(positions[i])))];
    weights[i] += std::llround(static_cast<double>(kBodyWeight) * triangle_weight * t);
  }
  return weights;
}

void check_world_count(int k, const CellBox& box, const char* method) {
  if (k < 1)
    throw GridError(std::string(method) + ": the number of territories must be >= 1, got " +
                    std::to_string(k));
  if (k > box.count())
    throw GridError(std::string(method) + ": cannot make " + std::to_string(k) +
                    " contiguous territories from the " + std::to_string(box.count()) +
                    " cells of the grid box " + to_string(box) +
                    " (each territory needs at least one cell); use fewer territories, "
                    "a smaller cell size or a larger margin");
}

}  // namespace detail

TerritoryMap make_partition(const std::string& spec, const Scene& scene, int k,
                            const GridOptions& options) {
  if (k < 1)
    throw GridError("partition '" + spec + "': the number of territories must be >= 1, got " +
                    std::to_string(k));
  if (spec == "kmeans") return partition_kmeans(scene, k, options);
  if (spec == "rcb") return partition_rcb(scene, k, options);
  if (spec.starts_with("grid:")) return partition_blocks(parse_block_spec(spec), scene, k, options);
  if (spec.starts_with("file:")) return load_territory_map(spec.substr(5), k);
  std::error_code ec;
  if (!spec.empty() && std::filesystem::is_regular_file(spec, ec))
    return load_territory_map(spec, k);
  throw GridError("unknown partition spec '" + spec +
                  "': expected one of kmeans, rcb, grid:AxBxC (e.g. grid:2x1x1), "
                  "file:PATH, or the path of an existing territory-map file");
}

TerritoryMap partition_kmeans(const Scene& scene, int k, const GridOptions& options) {
  const UniformGrid grid = make_grid(scene, options);
  const CellBox box = make_box(scene, grid, options);
  detail::check_world_count(k, box, "kmeans");
  const std::vector<Vec3> points = detail::dynamic_positions(scene);
  if (points.empty()) return partition_rcb(scene, k, options);
  const std::vector<std::int64_t> body_weights =
      detail::dynamic_weights(scene, grid, box, options.triangle_weight);
  const KMeansResult km =
      equal_size_kmeans(points, body_weights, k, options.seed, options.kmeans_max_iterations);

  // Majority owner per cell by weight (thesis 3.2.4); ties to the smallest
  // label.
  const auto n_cells = static_cast<std::size_t>(box.count());
  std::vector<std::tuple<std::size_t, int, std::int64_t>> votes;
  votes.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    votes.emplace_back(box.index(box.clamp(grid.cell_of(points[i]))), km.labels[i], body_weights[i]);
  std::sort(votes.begin(), votes.end());
  std::vector<WorldId> owners(n_cells, kNoWorld);
  std::vector<std::int64_t> weight(n_cells, 0);
  for (std::size_t run = 0; run < votes.size();) {
    const std::size_t cell = std::get<0>(votes[run]);
    std::int64_t best_weight = 0, total = 0;
    int best = -1;
    std::size_t j = run;
    while (j < votes.size() && std::get<0>(votes[j]) == cell) {
      std::size_t e = j;
      std::int64_t w = 0;
      for (; e < votes.size() && std::get<0>(votes[e]) == cell && std::get<1>(votes[e]) == std::get<1>(votes[j]); ++e)
        w += std::get<2>(votes[e]);
      if (w > best_weight) {  // labels ascending: strict > keeps the smallest on ties
        best_weight = w;
        best = std::get<1>(votes[j]);
      }
      total += w;
      j = e;
    }
    owners[cell] = best;
    weight[cell] = total;
    run = j;
  }
  detail::fill_unowned(box, owners);
  detail::enforce_contiguity(box, owners, k, weight);
  detail::fill_empty_worlds(box, owners, k);
  detail::renumber_canonical(owners, k);
  detail::verify_partition(box, owners, k);
  return TerritoryMap(grid, box, std::move(owners), k);
}

int territory_pieces(const TerritoryMap& map, WorldId world) {
  map.cell_count(world);  // checks the id
  return detail::count_pieces(map.box(), map.owners(), world);
}

PartitionStats partition_stats(const TerritoryMap& map, const Scene& scene, double triangle_weight) {
  PartitionStats s;
  const auto k = static_cast<std::size_t>(map.world_count());
  s.bodies_per_world.assign(k, 0);
  s.cells_per_world.assign(k, 0);
  s.weight_per_world.assign(k, 0.0);
  s.body_triangles_per_world.assign(k, 0);
  for (std::size_t w = 0; w < k; ++w) s.cells_per_world[w] = map.cell_count(static_cast<WorldId>(w));
  const std::vector<Vec3> positions = detail::dynamic_positions(scene);
  const std::vector<std::int64_t> weights = detail::dynamic_weights(scene, map.grid(), map.box(), triangle_weight);
  const std::vector<std::int32_t> triangles = has_level_geometry(scene.bodies)
                                                  ? cell_triangles(scene.bodies, map.grid(), map.box())
                                                  : std::vector<std::int32_t>{};
  std::int64_t total_weight = 0;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const auto w = static_cast<std::size_t>(map.owner_of(positions[i]));
    ++s.bodies_per_world[w];
    s.weight_per_world[w] += static_cast<double>(weights[i]) / static_cast<double>(detail::kBodyWeight);
    total_weight += weights[i];
    if (!triangles.empty())
      s.body_triangles_per_world[w] += triangles[map.box().index(map.box().clamp(map.grid().cell_of(positions[i])))];
  }
  if (!positions.empty()) {
    const double mean = static_cast<double>(positions.size()) / static_cast<double>(k);
    const auto max = *std::max_element(s.bodies_per_world.begin(), s.bodies_per_world.end());
    s.imbalance = static_cast<double>(max) / mean;
    const double weight_mean =
        static_cast<double>(total_weight) / static_cast<double>(detail::kBodyWeight) / static_cast<double>(k);
    s.weighted_imbalance = *std::max_element(s.weight_per_world.begin(), s.weight_per_world.end()) / weight_mean;
  }
  return s;
}

}  // namespace soda
