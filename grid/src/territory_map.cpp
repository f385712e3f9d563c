// TerritoryMap (territory_map.h).
#include "soda/grid/territory_map.h"

#include "foreign_cells.h"
#include "neighbours_within.h"

#include <algorithm>

namespace soda {

TerritoryMap::TerritoryMap() : TerritoryMap(UniformGrid(), CellBox{}, {0}, 1) {}

TerritoryMap::TerritoryMap(const UniformGrid& grid, const CellBox& box,
                           std::vector<WorldId> owners, int world_count)
    : TerritoryMap(grid, box, std::move(owners), world_count, 1) {}

TerritoryMap::TerritoryMap(const UniformGrid& grid, const CellBox& box, std::vector<WorldId> owners,
                           int world_count, int reach)
    : grid_(grid), box_(box), world_count_(world_count) {
  if (reach < 1 || reach > kMaxReachCells)
    throw GridError("territory map reach " + std::to_string(reach) + " cells is outside 1.." +
                    std::to_string(kMaxReachCells));
  if (!box.valid()) throw GridError("territory map box " + to_string(box) + " is empty");
  if (box.count() > kMaxBoxCells)
    throw GridError("territory map box " + to_string(box) + " holds more than " +
                    std::to_string(kMaxBoxCells) + " cells");
  if (world_count < 1)
    throw GridError("territory map needs at least one world, got " +
                    std::to_string(world_count));
  if (static_cast<std::int64_t>(owners.size()) != box.count())
    throw GridError("territory map has " + std::to_string(owners.size()) +
                    " owners for a box of " + std::to_string(box.count()) + " cells");
  auto data = std::make_shared<Data>();
  data->cell_counts.assign(static_cast<std::size_t>(world_count), 0);
  for (std::size_t i = 0; i < owners.size(); ++i) {
    const WorldId w = owners[i];
    if (w < 0 || w >= world_count)
      throw GridError("territory map: cell " + to_string(box.cell_at(i)) + " has owner " +
                      std::to_string(w) + ", outside 0.." + std::to_string(world_count - 1));
    ++data->cell_counts[static_cast<std::size_t>(w)];
  }

  data->neighbours = detail::neighbours_within(box, owners, world_count, reach);
  data->reach = reach;
  data->owners = std::move(owners);
  data_ = std::move(data);
}

void TerritoryMap::check_world(WorldId world) const {
  if (world < 0 || world >= world_count_)
    throw GridError("world id " + std::to_string(world) + " is outside 0.." +
                    std::to_string(world_count_ - 1));
}

std::vector<CellCoord> TerritoryMap::cells_of(WorldId world) const {
  check_world(world);
  std::vector<CellCoord> cells;
  cells.reserve(static_cast<std::size_t>(cell_count(world)));
  const auto& owners = data_->owners;
  for (std::size_t i = 0; i < owners.size(); ++i)
    if (owners[i] == world) cells.push_back(box_.cell_at(i));
  return cells;
}

std::int64_t TerritoryMap::cell_count(WorldId world) const {
  check_world(world);
  return data_->cell_counts[static_cast<std::size_t>(world)];
}

const std::vector<WorldId>& TerritoryMap::neighbours(WorldId world) const {
  check_world(world);
  return data_->neighbours[static_cast<std::size_t>(world)];
}

std::vector<ForeignCell> TerritoryMap::foreign_cells(WorldId world, const Vec3& min,
                                                     const Vec3& max) const {
  check_world(world);
  return detail::foreign_cells_in(grid_, world, min, max, [this](const CellCoord& c) { return owner(c); });
}

TerritoryMap TerritoryMap::reassigned(
    std::span<const std::pair<CellCoord, WorldId>> changes) const {
  std::vector<WorldId> owners = data_->owners;
  for (const auto& [cell, w] : changes) {
    if (!box_.contains(cell))
      throw GridError("reassigned: cell " + to_string(cell) + " lies outside the map box " +
                      to_string(box_));
    check_world(w);
    owners[box_.index(cell)] = w;
  }
  return TerritoryMap(grid_, box_, std::move(owners), world_count_, reach());
}

TerritoryMap TerritoryMap::with_reach(int cells) const {
  if (cells == reach()) return *this;
  return TerritoryMap(grid_, box_, data_->owners, world_count_, cells);
}

bool operator==(const TerritoryMap& a, const TerritoryMap& b) {
  return a.grid_ == b.grid_ && a.box_ == b.box_ && a.world_count_ == b.world_count_ &&
         (a.data_ == b.data_ || (a.data_->reach == b.data_->reach && a.data_->owners == b.data_->owners));
}

}  // namespace soda
