// make_partition (the spec dispatcher), the k-means partition, and the
// helpers every method shares.
#include "soda/grid/partition.h"

#include <algorithm>
#include <filesystem>

#include "partition_detail.h"
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
  const KMeansResult km =
      equal_size_kmeans(points, k, options.seed, options.kmeans_max_iterations);

  // Majority owner per cell (thesis 3.2.4); ties to the smallest label.
  const auto n_cells = static_cast<std::size_t>(box.count());
  std::vector<std::pair<std::size_t, int>> votes;
  votes.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    votes.emplace_back(box.index(box.clamp(grid.cell_of(points[i]))), km.labels[i]);
  std::sort(votes.begin(), votes.end());
  std::vector<WorldId> owners(n_cells, kNoWorld);
  std::vector<std::int64_t> weight(n_cells, 0);
  for (std::size_t run = 0; run < votes.size();) {
    const std::size_t cell = votes[run].first;
    std::size_t best_count = 0;
    int best = -1;
    std::size_t j = run;
    while (j < votes.size() && votes[j].first == cell) {
      std::size_t e = j;
      while (e < votes.size() && votes[e].first == cell && votes[e].second == votes[j].second) ++e;
      if (e - j > best_count) {  // labels ascending: strict > keeps the smallest on ties
        best_count = e - j;
        best = votes[j].second;
      }
      j = e;
    }
    owners[cell] = best;
    weight[cell] = static_cast<std::int64_t>(j - run);
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

PartitionStats partition_stats(const TerritoryMap& map, const Scene& scene) {
  PartitionStats s;
  const auto k = static_cast<std::size_t>(map.world_count());
  s.bodies_per_world.assign(k, 0);
  s.cells_per_world.assign(k, 0);
  for (std::size_t w = 0; w < k; ++w) s.cells_per_world[w] = map.cell_count(static_cast<WorldId>(w));
  std::int64_t total = 0;
  for (const Body& b : scene.bodies) {
    if (b.is_static) continue;
    ++s.bodies_per_world[static_cast<std::size_t>(map.owner_of(b.position))];
    ++total;
  }
  if (total > 0) {
    const double mean = static_cast<double>(total) / static_cast<double>(k);
    const auto max = *std::max_element(s.bodies_per_world.begin(), s.bodies_per_world.end());
    s.imbalance = static_cast<double>(max) / mean;
  }
  return s;
}

}  // namespace soda
