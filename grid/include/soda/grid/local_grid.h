// A world's local grid: its own cells plus a margin of the map's reach (one
// cell unless TerritoryMap::with_reach widened it) whose cells carry their
// owners' ids, so the world knows its neighbours and nothing more (the
// thesis, 3.2.1 and 3.2.4).
//
// Invariants (kept by LocalGrid):
//  1. the local grid answers the owner of every cell of Z^3 that the world
//     owns or that lies within the map's reach of a cell it owns (reach 1:
//     face-, edge- or corner-adjacent), and
//     gives the same answer as the TerritoryMap it was built from;
//  2. cells it does not know answer kNoWorld, never a guess;
//  3. neighbours() equals TerritoryMap::neighbours(world).
#pragma once

#include <vector>

#include "soda/grid/territory_map.h"

namespace soda {

/// One world's view of the territory map. Plain value: safe to read from
/// many threads at once, not to mutate concurrently.
class LocalGrid {
 public:
  /// Builds the view of `world` from a map. Throws GridError for a world id
  /// outside [0, map.world_count()).
  LocalGrid(const TerritoryMap& map, WorldId world);

  /// The world whose view this is.
  WorldId world() const { return world_; }
  /// The map's grid.
  const UniformGrid& grid() const { return grid_; }
  /// Cells stored: the bounding box of the world's cells inside the map box,
  /// grown by the map's reach and clipped to the map box. Invalid (lo > hi) when the
  /// world owns no cell.
  const CellBox& box() const { return box_; }

  /// True if the world owns the cell (any cell of Z^3).
  bool owns(const CellCoord& cell) const { return owner(cell) == world_; }
  /// Owner of an own or margin cell (invariant 1), kNoWorld for a cell the
  /// world does not know (invariant 2).
  WorldId owner(const CellCoord& cell) const;
  /// Owner of the cell holding a position (metres); kNoWorld if unknown.
  /// Throws GridError if p is not finite.
  WorldId owner_of(const Vec3& p) const { return owner(grid_.cell_of(p)); }
  /// True if the cell is known and owned by another world.
  bool is_margin(const CellCoord& cell) const {
    const WorldId w = owner(cell);
    return w != kNoWorld && w != world_;
  }

  /// Own cells inside the map box, canonical order.
  std::vector<CellCoord> own_cells() const;
  /// Margin cells inside the map box with their owners, canonical order.
  std::vector<ForeignCell> margin_cells() const;
  /// Worlds owning a margin cell, ascending (invariant 3).
  const std::vector<WorldId>& neighbours() const { return neighbours_; }

  /// Foreign cells overlapped by the closed AABB [min, max] (metres), with
  /// their owners, canonical order; as TerritoryMap::foreign_cells, except
  /// that cells beyond the margin are reported with owner kNoWorld. Throws
  /// GridError for a bad AABB or one covering more than kMaxQueryCells cells.
  std::vector<ForeignCell> foreign_cells(const Vec3& min, const Vec3& max) const;

 private:
  WorldId world_ = kNoWorld;
  UniformGrid grid_;
  CellBox map_box_;
  CellBox box_;
  std::vector<WorldId> owners_;  // per box_ cell: own id, margin owner or kNoWorld
  std::vector<WorldId> neighbours_;
};

}  // namespace soda
