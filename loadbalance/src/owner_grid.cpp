#include "owner_grid.h"

#include <array>

namespace soda::detail {
namespace {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

std::uint64_t tie_break(std::uint64_t seed, std::int64_t step, std::uint64_t key) {
  return splitmix64(splitmix64(splitmix64(seed) ^ static_cast<std::uint64_t>(step)) ^ key);
}

OwnerGrid::OwnerGrid(const TerritoryMap& map)
    : box_(map.box()),
      world_count_(map.world_count()),
      owners_(map.owners().begin(), map.owners().end()),
      counts_(static_cast<std::size_t>(map.world_count()), 0) {
  for (WorldId w : owners_) ++counts_[static_cast<std::size_t>(w)];
}

void OwnerGrid::set(const CellCoord& c, WorldId world) {
  WorldId& o = owners_[box_.index(c)];
  --counts_[static_cast<std::size_t>(o)];
  o = world;
  ++counts_[static_cast<std::size_t>(o)];
}

FaceCounts OwnerGrid::faces(const CellCoord& c, WorldId giver, WorldId recipient) const {
  FaceCounts f;
  for (const CellCoord& d : kFaceOffsets) {
    const WorldId o = owner(offset(c, d));
    if (o == kNoWorld) continue;
    if (o == giver) ++f.giver;
    else if (o == recipient) ++f.recipient;
    else ++f.other;
  }
  return f;
}

bool OwnerGrid::touches(const CellCoord& c, WorldId world) const {
  for (const CellCoord& d : kFaceOffsets)
    if (owner(offset(c, d)) == world) return true;
  return false;
}

int OwnerGrid::foreign_neighbours(const CellCoord& c, WorldId world) const {
  int n = 0;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const WorldId o = owner({c.x + dx, c.y + dy, c.z + dz});
        if (o != kNoWorld && o != world) ++n;
      }
  return n;
}

bool OwnerGrid::removable(const CellCoord& c, WorldId world) const {
  if (cell_count(world) <= 1) return false;
  // The 3 x 3 x 3 block around c, index (dx+1)*9 + (dy+1)*3 + (dz+1); c
  // itself (13) left out.
  std::array<bool, 27> mine{};
  for (int i = 0; i < 27; ++i) {
    if (i == 13) continue;
    mine[static_cast<std::size_t>(i)] = owner({c.x + i / 9 - 1, c.y + (i / 3) % 3 - 1, c.z + i % 3 - 1}) == world;
  }
  constexpr std::array<int, 6> kFaces = {4, 22, 10, 16, 12, 14};  // -x, +x, -y, +y, -z, +z
  int start = -1, face_cells = 0;
  for (int f : kFaces)
    if (mine[static_cast<std::size_t>(f)]) {
      ++face_cells;
      if (start < 0) start = f;
    }
  if (face_cells == 0) return true;  // c touched none of its own cells: an island already
  // Flood fill over the block's own cells by face steps from one face cell.
  std::array<bool, 27> seen{};
  std::array<int, 27> stack{};
  int top = 0;
  stack[top++] = start;
  seen[static_cast<std::size_t>(start)] = true;
  while (top > 0) {
    const int i = stack[--top];
    const int x = i / 9, y = (i / 3) % 3, z = i % 3;
    const int next[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z}, {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
    for (const auto& n : next) {
      if (n[0] < 0 || n[0] > 2 || n[1] < 0 || n[1] > 2 || n[2] < 0 || n[2] > 2) continue;
      const int j = n[0] * 9 + n[1] * 3 + n[2];
      if (!mine[static_cast<std::size_t>(j)] || seen[static_cast<std::size_t>(j)]) continue;
      seen[static_cast<std::size_t>(j)] = true;
      stack[top++] = j;
    }
  }
  for (int f : kFaces)
    if (mine[static_cast<std::size_t>(f)] && !seen[static_cast<std::size_t>(f)]) return false;
  return true;
}

}  // namespace soda::detail
