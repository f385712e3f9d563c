// TerritoryMap (territory_map.h).
#include "soda/grid/territory_map.h"

#include "foreign_cells.h"

#include <algorithm>

namespace soda {

TerritoryMap::TerritoryMap() : TerritoryMap(UniformGrid(), CellBox{}, {0}, 1) {}

TerritoryMap::TerritoryMap(const UniformGrid& grid, const CellBox& box,
                           std::vector<WorldId> owners, int world_count)
    : grid_(grid), box_(box), world_count_(world_count) {
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

  // Neighbour pairs over the 13 "forward" offsets of the 26-neighbourhood;
  // each unordered pair of adjacent cells is seen once.
  std::vector<std::pair<WorldId, WorldId>> pairs;
  for (int x = box.lo.x; x <= box.hi.x; ++x)
    for (int y = box.lo.y; y <= box.hi.y; ++y)
      for (int z = box.lo.z; z <= box.hi.z; ++z) {
        const WorldId a = owners[box.index({x, y, z})];
        for (int dx = 0; dx <= 1; ++dx)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dz = -1; dz <= 1; ++dz) {
              if (dx == 0 && (dy < 0 || (dy == 0 && dz <= 0))) continue;
              const CellCoord n{x + dx, y + dy, z + dz};
              if (!box.contains(n)) continue;
              const WorldId b = owners[box.index(n)];
              if (a != b) pairs.emplace_back(std::min(a, b), std::max(a, b));
            }
      }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  data->neighbours.resize(static_cast<std::size_t>(world_count));
  for (const auto& [a, b] : pairs) {
    data->neighbours[static_cast<std::size_t>(a)].push_back(b);
    data->neighbours[static_cast<std::size_t>(b)].push_back(a);
  }
  for (auto& list : data->neighbours) std::sort(list.begin(), list.end());
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
  return TerritoryMap(grid_, box_, std::move(owners), world_count_);
}

bool operator==(const TerritoryMap& a, const TerritoryMap& b) {
  return a.grid_ == b.grid_ && a.box_ == b.box_ && a.world_count_ == b.world_count_ &&
         (a.data_ == b.data_ || a.data_->owners == b.data_->owners);
}

}  // namespace soda
