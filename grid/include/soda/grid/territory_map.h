// The territory map: which world owns each cell of Z^3.
//
// Invariants (kept by TerritoryMap):
//  1. every cell of Z^3 has exactly one owner, a world id in [0, world_count);
//     bodies that fly off the scene always have an owner;
//  2. owners are stored for an explicit box of cells; a cell outside the box
//     belongs to the owner of the nearest box cell (coordinates clamped into
//     the box). Clamping keeps adjacent cells adjacent (or merges them), so a
//     territory connected inside the box stays connected in Z^3 and two
//     worlds are neighbours in Z^3 exactly when they are inside the box;
//  3. neighbours(w) are the worlds other than w owning a cell within reach()
//     cells of a cell of w (Chebyshev distance: reach 1 is face-, edge- or
//     corner-adjacency, the 26-neighbourhood); the relation is symmetric;
//  4. every list returned is in canonical order (cells lexicographic by
//     (x, y, z), worlds ascending), never in hash or address order;
//  5. the map is immutable: copies share one storage block, so copying is
//     O(1); reassigned() and with_reach() make a new map and leave this one
//     untouched.
// make_partition adds: every world owns at least one cell and its cells are
// 6-connected (see partition.h). The map itself does not require either, so
// that cessions can be expressed with reassigned().
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "soda/grid/grid.h"

namespace soda {

/// Identifier of a world (a territory), 0 .. world_count - 1.
using WorldId = std::int32_t;
/// "No world": returned for cells a local grid does not know.
inline constexpr WorldId kNoWorld = -1;
/// Largest reach (cells) a map accepts: a body crossing more than this many
/// cells per step needs a coarser grid, not a wider neighbourhood (at the
/// bound every world of any practical map is everyone's neighbour already).
inline constexpr int kMaxReachCells = 1024;
/// Most cells one foreign_cells() query may cover (a sanity bound: the AABB of
/// a body is at most a few cells wide).
inline constexpr std::int64_t kMaxQueryCells = std::int64_t{1} << 20;

/// A cell together with the world owning it.
struct ForeignCell {
  CellCoord cell;
  WorldId owner = kNoWorld;
  friend bool operator==(const ForeignCell&, const ForeignCell&) = default;
};

/// Cell -> world id for every cell of Z^3. Immutable value, O(1) to copy;
/// every member is safe to call from many threads at once.
class TerritoryMap {
 public:
  /// One world owning all of Z^3 (a one-cell box at the origin, unit cells).
  TerritoryMap();
  /// owners: one world id per box cell in box index order (x slowest, z
  /// fastest). Throws GridError if the box is invalid or larger than
  /// kMaxBoxCells, world_count < 1, owners.size() != box.count(), or an owner
  /// lies outside [0, world_count).
  TerritoryMap(const UniformGrid& grid, const CellBox& box, std::vector<WorldId> owners,
               int world_count);

  /// The grid the map's cells belong to.
  const UniformGrid& grid() const { return grid_; }
  /// The box of cells whose owners are stored (invariant 2).
  const CellBox& box() const { return box_; }
  /// Number of worlds K; ids are 0 .. K-1.
  int world_count() const { return world_count_; }
  /// Owners of the box cells, in box index order.
  std::span<const WorldId> owners() const { return data_->owners; }

  /// Owner of any cell of Z^3 (invariant 2).
  WorldId owner(const CellCoord& cell) const {
    return data_->owners[box_.index(box_.clamp(cell))];
  }
  /// Owner of the cell holding a position, metres. Throws GridError if p is
  /// not finite.
  WorldId owner_of(const Vec3& p) const { return owner(grid_.cell_of(p)); }

  /// Box cells owned by a world, in canonical order. Throws GridError for an
  /// id outside [0, world_count).
  std::vector<CellCoord> cells_of(WorldId world) const;
  /// Number of box cells owned by a world. Throws as cells_of.
  std::int64_t cell_count(WorldId world) const;
  /// Neighbours of a world (invariant 3), ascending. Throws as cells_of.
  const std::vector<WorldId>& neighbours(WorldId world) const;
  /// How far, in cells (Chebyshev distance), a world's neighbours reach: 1
  /// (adjacent cells) unless the map was made by with_reach().
  int reach() const { return data_->reach; }
  /// The same owners with neighbours reaching `cells` cells (the partitioned
  /// runtime widens the neighbourhood so that a fast body's halo and its
  /// migration stay among neighbours: docs/partitioned-step.md, "Reach").
  /// O(sum over worlds of the cells within `cells` of their bounding box).
  /// Throws GridError for cells outside 1..kMaxReachCells.
  TerritoryMap with_reach(int cells) const;

  /// Cells overlapped by the closed AABB [min, max] (metres; see
  /// UniformGrid::cells_overlapping) that `world` does not own, with their
  /// owners, in canonical cell order. Cells outside the box are included with
  /// their clamped owner. Throws GridError for a bad AABB or world id, or an
  /// AABB covering more than kMaxQueryCells cells.
  std::vector<ForeignCell> foreign_cells(WorldId world, const Vec3& min,
                                         const Vec3& max) const;

  /// A new map with the given box cells given to new owners (same grid, box,
  /// world count and reach). Throws GridError for a cell outside the box or an
  /// owner outside [0, world_count).
  TerritoryMap reassigned(std::span<const std::pair<CellCoord, WorldId>> changes) const;

  /// Same grid, box, world count, reach and owners.
  friend bool operator==(const TerritoryMap& a, const TerritoryMap& b);

 private:
  struct Data {
    std::vector<WorldId> owners;
    std::vector<std::vector<WorldId>> neighbours;  // per world
    std::vector<std::int64_t> cell_counts;         // per world
    int reach = 1;                                 // of neighbours, cells
  };
  TerritoryMap(const UniformGrid& grid, const CellBox& box, std::vector<WorldId> owners, int world_count,
               int reach);
  void check_world(WorldId world) const;

  UniformGrid grid_;
  CellBox box_;
  int world_count_ = 1;
  std::shared_ptr<const Data> data_;
};

}  // namespace soda
