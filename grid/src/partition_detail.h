// Internal helpers shared by the partition methods: work on the owners of a
// box of cells (one WorldId per box cell, box index order). Not public API.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda::detail {

/// Dynamic bodies' positions, ordered by body id (scene order is arbitrary).
std::vector<Vec3> dynamic_positions(const Scene& scene);

/// What one dynamic body weighs in a partition: kBodyWeight.
inline constexpr std::int64_t kBodyWeight = 1000;
/// Integer weight of each dynamic body, in the order of dynamic_positions:
/// kBodyWeight x (1 + triangle_weight x the triangles within its home
/// cell's reach, cell_triangles.h), rounded. All kBodyWeight when the scene
/// has no mesh or heightfield or the weight is 0 (the partitions are then
/// those of bodies alone). Throws GridError for a weight that is not finite
/// and >= 0.
std::vector<std::int64_t> dynamic_weights(const Scene& scene, const UniformGrid& grid, const CellBox& box,
                                          double triangle_weight);

/// Throws GridError unless 1 <= k <= box.count(), with a message for `method`.
void check_world_count(int k, const CellBox& box, const char* method);

/// Cells owned by kNoWorld take the owner of the nearest owned cell (6-step
/// distance); equidistant candidates go to the smallest world id. Requires at
/// least one owned cell.
void fill_unowned(const CellBox& box, std::vector<WorldId>& owners);

/// Until every world is 6-connected: each piece of a world other than its main
/// piece (most weight, then most cells, then first in box order) goes to the
/// world it shares most faces with (ties: smallest id). weight: per box cell.
void enforce_contiguity(const CellBox& box, std::vector<WorldId>& owners, int k,
                        const std::vector<std::int64_t>& weight);

/// Gives every world of 0..k-1 that owns no cell one cell: a leaf of the BFS
/// tree of the world with most cells (ties: smallest id), so the donor stays
/// connected. Requires k <= box.count() and connected territories.
void fill_empty_worlds(const CellBox& box, std::vector<WorldId>& owners, int k);

/// Renumbers worlds by the box index of their first cell.
void renumber_canonical(std::vector<WorldId>& owners, int k);

/// Number of 6-connected pieces of each world 0..k-1 (owners all in range).
std::vector<int> pieces_per_world(const CellBox& box, std::span<const WorldId> owners, int k);

/// Throws std::logic_error unless each world of 0..k-1 owns exactly one
/// 6-connected piece (a bug check: the partition methods guarantee it).
void verify_partition(const CellBox& box, const std::vector<WorldId>& owners, int k);

/// Number of 6-connected pieces of one world's cells.
int count_pieces(const CellBox& box, std::span<const WorldId> owners, WorldId world);

/// Calls f(neighbour_index) for each face neighbour of box cell i inside the
/// box, in the order -x, +x, -y, +y, -z, +z.
template <class F>
void for_each_face_neighbour(const CellBox& box, std::size_t i, F&& f) {
  const auto ez = static_cast<std::size_t>(box.extent(2));
  const auto ey = static_cast<std::size_t>(box.extent(1));
  const auto ex = static_cast<std::size_t>(box.extent(0));
  const std::size_t z = i % ez;
  const std::size_t y = (i / ez) % ey;
  const std::size_t x = i / (ez * ey);
  const std::size_t sx = ey * ez;
  if (x > 0) f(i - sx);
  if (x + 1 < ex) f(i + sx);
  if (y > 0) f(i - ez);
  if (y + 1 < ey) f(i + ez);
  if (z > 0) f(i - 1);
  if (z + 1 < ez) f(i + 1);
}

}  // namespace soda::detail
