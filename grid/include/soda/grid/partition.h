// Initial partitions: cutting the grid into K territories.
//
// Invariants of every map make_partition returns:
//  1. world ids are 0 .. K-1 and every world owns at least one box cell;
//  2. every territory is 6-connected (face adjacency) inside the box, hence
//     in Z^3 (territory_map.h, invariant 2);
//  3. same inputs, same map: no dependence on body order in the scene (bodies
//     are taken by id), on hash order or on addresses;
//  4. kmeans and rcb number worlds by their first cell in canonical order;
//     grid:AxBxC numbers blocks (i * B + j) * C + k; files keep their ids.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda {

/// Builds the territory map named by spec (invariants 1-4):
///   "kmeans"      equal-size k-means on dynamic body positions, majority
///                 owner per cell, empty cells to the nearest territory, then
///                 contiguity enforced (partition_kmeans);
///   "rcb"         recursive coordinate bisection (partition_rcb);
///   "grid:AxBxC"  A x B x C regular blocks over the box (partition_blocks);
///   "file:PATH" or a PATH to an existing file: a territory-map file
///                 (map_file.h); its cell size, origin and box replace
///                 options'.
/// k is the number of territories; for grid: and file specs it must equal the
/// number the spec makes. Throws GridError for k < 1, k larger than the
/// number of box cells, an unknown spec (the message lists the choices), a bad
/// cell-size override, or a bad file. Pure function; thread-safe.
TerritoryMap make_partition(const std::string& spec, const Scene& scene, int k,
                            const GridOptions& options);

/// Equal-size k-means partition (spec "kmeans"). Falls back to rcb when the
/// scene has no dynamic body. Throws as make_partition.
TerritoryMap partition_kmeans(const Scene& scene, int k, const GridOptions& options);

/// Recursive coordinate bisection (spec "rcb"): a region is split along its
/// longest axis (in cells; ties x, then y, then z) at the cell boundary that
/// puts the share floor(K/2)/K of the region's dynamic bodies nearest below
/// it (ties: the share of cells, then the lower boundary), and floor(K/2),
/// ceil(K/2) territories go to the two sides; if that axis cannot hold such a
/// split the next longest is tried, and failing all, the counts are shifted so
/// each side keeps at least one cell per territory. Throws as make_partition.
TerritoryMap partition_rcb(const Scene& scene, int k, const GridOptions& options);

/// Slabs per axis of a regular block partition.
struct BlockSpec {
  int a = 1;  // slabs along x
  int b = 1;  // slabs along y
  int c = 1;  // slabs along z
};
/// Parses "grid:AxBxC" (A, B, C positive integers). Throws GridError with the
/// expected form on anything else.
BlockSpec parse_block_spec(const std::string& spec);

/// Regular blocks over the box: along x, slab i (0 <= i < A) holds the cells
/// with box.lo.x + floor(i * nx / A) <= x < box.lo.x + floor((i + 1) * nx / A),
/// nx = box.extent(x); likewise y and z. Block (i, j, l) is world
/// (i * B + j) * C + l. Throws GridError if k != A * B * C or an axis has
/// fewer cells than slabs.
TerritoryMap partition_blocks(const BlockSpec& blocks, const Scene& scene, int k,
                              const GridOptions& options);

/// Number of 6-connected pieces a world's box cells form (0 if it owns none).
/// Throws GridError for a bad world id.
int territory_pieces(const TerritoryMap& map, WorldId world);

/// Balance of a map over a scene's dynamic bodies.
struct PartitionStats {
  std::vector<std::int64_t> bodies_per_world;  // dynamic bodies by owner_of(position)
  std::vector<std::int64_t> cells_per_world;   // box cells
  double imbalance = 1.0;                      // max / mean bodies per world; 1 = even
  /// Per world: its bodies weighed as the partitions weigh them, 1 +
  /// triangle_weight x the triangles within reach of the body's home cell
  /// (cell_triangles.h), in bodies.
  std::vector<double> weight_per_world;
  /// Per world: the triangles within reach of its bodies' home cells,
  /// summed over its bodies.
  std::vector<std::int64_t> body_triangles_per_world;
  double weighted_imbalance = 1.0;  // max / mean weight per world
};
/// Counts bodies, cells and weights per world (triangle_weight as
/// GridOptions::triangle_weight). Thread-safe.
PartitionStats partition_stats(const TerritoryMap& map, const Scene& scene,
                               double triangle_weight = kTriangleWeight);

}  // namespace soda
