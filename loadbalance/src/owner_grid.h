// OwnerGrid: a mutable copy of a territory map's box owners, with the shape
// queries the cession policies ask while they plan moves (faces shared with
// each world, foreign neighbours, whether giving a cell away would split a
// territory). Cells outside the box count as nobody's: the box border is the
// scene's border, not a border between worlds.
//
// Thread safety: a plain value; one thread at a time.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda::detail {

/// Faces of a cell shared with the giver, the recipient and other worlds
/// (box cells only).
struct FaceCounts {
  int giver = 0;
  int recipient = 0;
  int other = 0;
};

class OwnerGrid {
 public:
  explicit OwnerGrid(const TerritoryMap& map);

  const CellBox& box() const { return box_; }
  int world_count() const { return world_count_; }
  /// Owner of a cell; kNoWorld outside the box.
  WorldId owner(const CellCoord& c) const {
    return box_.contains(c) ? owners_[box_.index(c)] : kNoWorld;
  }
  /// Gives a box cell to `world` (keeps the per-world counts).
  void set(const CellCoord& c, WorldId world);
  /// Box cells a world owns.
  std::int64_t cell_count(WorldId world) const { return counts_[static_cast<std::size_t>(world)]; }

  /// Faces of c shared with `giver`, `recipient`, and any other world.
  FaceCounts faces(const CellCoord& c, WorldId giver, WorldId recipient) const;
  /// True if a face neighbour of c is owned by `world`.
  bool touches(const CellCoord& c, WorldId world) const;
  /// Box cells of the 26-neighbourhood of c owned by a world other than
  /// `world` (the thesis' "foreign neighbours" of a cell).
  int foreign_neighbours(const CellCoord& c, WorldId world) const;
  /// True if `world`'s cells among c's face neighbours stay 6-connected to
  /// each other inside c's 3 x 3 x 3 block once c is gone: then giving c
  /// away cannot split the territory (a sufficient, local test). False if
  /// c is the world's only cell.
  bool removable(const CellCoord& c, WorldId world) const;

 private:
  CellBox box_;
  int world_count_;
  std::vector<WorldId> owners_;
  std::vector<std::int64_t> counts_;
};

/// The six face offsets.
inline constexpr CellCoord kFaceOffsets[6] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0},
                                              {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};
inline CellCoord offset(const CellCoord& c, const CellCoord& d) { return {c.x + d.x, c.y + d.y, c.z + d.z}; }

/// A seeded hash for tie-breaks (splitmix64 of the three values mixed):
/// the same inputs always give the same order.
std::uint64_t tie_break(std::uint64_t seed, std::int64_t step, std::uint64_t key);

}  // namespace soda::detail
