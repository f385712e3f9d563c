// LocalGrid (local_grid.h).
#include "soda/grid/local_grid.h"

#include "foreign_cells.h"

#include <algorithm>

namespace soda {

LocalGrid::LocalGrid(const TerritoryMap& map, WorldId world)
    : world_(world), grid_(map.grid()), map_box_(map.box()) {
  const std::vector<CellCoord> own = map.cells_of(world);  // checks the id
  neighbours_ = map.neighbours(world);
  if (own.empty()) {
    box_ = {{0, 0, 0}, {-1, -1, -1}};
    return;
  }
  CellBox bounds{own.front(), own.front()};
  for (const CellCoord& c : own)
    for (int axis = 0; axis < 3; ++axis) {
      bounds.lo[axis] = std::min(bounds.lo[axis], c[axis]);
      bounds.hi[axis] = std::max(bounds.hi[axis], c[axis]);
    }
  const int r = map.reach();  // the margin reaches as far as the neighbours do
  bounds = bounds.grown(r);
  for (int axis = 0; axis < 3; ++axis) {
    bounds.lo[axis] = std::max(bounds.lo[axis], map_box_.lo[axis]);
    bounds.hi[axis] = std::min(bounds.hi[axis], map_box_.hi[axis]);
  }
  box_ = bounds;
  owners_.assign(static_cast<std::size_t>(box_.count()), kNoWorld);
  for (const CellCoord& c : own) owners_[box_.index(c)] = world_;
  // Margin: every box cell within r of an own cell carries its owner.
  for (const CellCoord& c : own)
    for (int dx = -r; dx <= r; ++dx)
      for (int dy = -r; dy <= r; ++dy)
        for (int dz = -r; dz <= r; ++dz) {
          const CellCoord n{c.x + dx, c.y + dy, c.z + dz};
          if (!box_.contains(n)) continue;
          WorldId& slot = owners_[box_.index(n)];
          if (slot == kNoWorld) slot = map.owner(n);
        }
}

WorldId LocalGrid::owner(const CellCoord& cell) const {
  // The map's rule for cells outside its box (clamping) applies here too.
  const CellCoord c = map_box_.clamp(cell);
  if (!box_.valid() || !box_.contains(c)) return kNoWorld;
  return owners_[box_.index(c)];
}

std::vector<CellCoord> LocalGrid::own_cells() const {
  std::vector<CellCoord> out;
  for (std::size_t i = 0; i < owners_.size(); ++i)
    if (owners_[i] == world_) out.push_back(box_.cell_at(i));
  return out;
}

std::vector<ForeignCell> LocalGrid::margin_cells() const {
  std::vector<ForeignCell> out;
  for (std::size_t i = 0; i < owners_.size(); ++i)
    if (owners_[i] != world_ && owners_[i] != kNoWorld)
      out.push_back({box_.cell_at(i), owners_[i]});
  return out;
}

std::vector<ForeignCell> LocalGrid::foreign_cells(const Vec3& min, const Vec3& max) const {
  return detail::foreign_cells_in(grid_, world_, min, max, [this](const CellCoord& c) { return owner(c); });
}

}  // namespace soda
