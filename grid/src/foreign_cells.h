// Internal: the "which foreign-owned cells does this AABB overlap" query,
// shared by TerritoryMap and LocalGrid (they differ only in how a cell's
// owner is looked up).
#pragma once

#include <string>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda::detail {

/// Cells overlapped by [min, max] whose owner (owner_of(CellCoord)) is not
/// `world`, in canonical (x, y, z) order. Throws GridError for an AABB
/// covering more than kMaxQueryCells cells.
template <class OwnerOf>
std::vector<ForeignCell> foreign_cells_in(const UniformGrid& grid, WorldId world, const Vec3& min, const Vec3& max,
                                          OwnerOf owner_of) {
  const CellBox range = grid.cells_overlapping(min, max);
  if (range.count() > kMaxQueryCells)
    throw GridError("foreign_cells: the AABB covers " + std::to_string(range.count()) +
                    " cells, more than the limit of " + std::to_string(kMaxQueryCells));
  std::vector<ForeignCell> out;
  for (int x = range.lo.x; x <= range.hi.x; ++x)
    for (int y = range.lo.y; y <= range.hi.y; ++y)
      for (int z = range.lo.z; z <= range.hi.z; ++z) {
        const WorldId w = owner_of(CellCoord{x, y, z});
        if (w != world) out.push_back({{x, y, z}, w});
      }
  return out;
}

}  // namespace soda::detail
