// detail::neighbours_within (neighbours_within.h).
#include "neighbours_within.h"

#include <algorithm>
#include <cstdint>
#include <utility>

namespace soda::detail {
namespace {

// reach 1: each unordered pair of adjacent cells is seen once, over the 13
// "forward" offsets of the 26-neighbourhood.
std::vector<std::pair<WorldId, WorldId>> adjacent_pairs(const CellBox& box, const std::vector<WorldId>& owners) {
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
  return pairs;
}

// Dilates a 0/1 mask over `region` by `reach` cells along one axis: a cell
// is set if a set cell lies within `reach` of it on its line.
void dilate_axis(std::vector<std::uint8_t>& mask, const CellBox& region, int axis, int reach) {
  const std::int64_t n[3] = {region.extent(0), region.extent(1), region.extent(2)};
  const std::int64_t stride[3] = {n[1] * n[2], n[2], 1};
  const int a1 = axis == 0 ? 1 : 0, a2 = axis == 2 ? 1 : 2;  // the two other axes
  std::vector<std::uint8_t> line(static_cast<std::size_t>(n[axis]));
  for (std::int64_t i = 0; i < n[a1]; ++i)
    for (std::int64_t j = 0; j < n[a2]; ++j) {
      const std::int64_t base = i * stride[a1] + j * stride[a2];
      for (std::int64_t k = 0; k < n[axis]; ++k) line[static_cast<std::size_t>(k)] = mask[static_cast<std::size_t>(base + k * stride[axis])];
      std::int64_t last = -(std::int64_t{reach} + 1) - 1;  // forward: distance to the last set cell
      for (std::int64_t k = 0; k < n[axis]; ++k) {
        if (line[static_cast<std::size_t>(k)]) last = k;
        if (k - last <= reach) mask[static_cast<std::size_t>(base + k * stride[axis])] = 1;
      }
      std::int64_t next = n[axis] + reach + 1;  // backward: distance to the next set cell
      for (std::int64_t k = n[axis] - 1; k >= 0; --k) {
        if (line[static_cast<std::size_t>(k)]) next = k;
        if (next - k <= reach) mask[static_cast<std::size_t>(base + k * stride[axis])] = 1;
      }
    }
}

}  // namespace

std::vector<std::vector<WorldId>> neighbours_within(const CellBox& box, const std::vector<WorldId>& owners,
                                                    int world_count, int reach) {
  std::vector<std::vector<WorldId>> out(static_cast<std::size_t>(world_count));
  if (reach == 1) {
    std::vector<std::pair<WorldId, WorldId>> pairs = adjacent_pairs(box, owners);
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    for (const auto& [a, b] : pairs) {
      out[static_cast<std::size_t>(a)].push_back(b);
      out[static_cast<std::size_t>(b)].push_back(a);
    }
    for (auto& list : out) std::sort(list.begin(), list.end());
    return out;
  }
  // Bounding box of every world's cells.
  std::vector<CellBox> bounds(static_cast<std::size_t>(world_count), CellBox{{0, 0, 0}, {-1, -1, -1}});
  for (std::size_t i = 0; i < owners.size(); ++i) {
    CellBox& b = bounds[static_cast<std::size_t>(owners[i])];
    const CellCoord c = box.cell_at(i);
    if (!b.valid()) {
      b = CellBox{c, c};
      continue;
    }
    for (int axis = 0; axis < 3; ++axis) {
      b.lo[axis] = std::min(b.lo[axis], c[axis]);
      b.hi[axis] = std::max(b.hi[axis], c[axis]);
    }
  }
  std::vector<std::uint8_t> mask, seen(static_cast<std::size_t>(world_count));
  for (WorldId w = 0; w < world_count; ++w) {
    const CellBox& b = bounds[static_cast<std::size_t>(w)];
    if (!b.valid()) continue;  // owns no box cell
    CellBox region = b.grown(reach);
    for (int axis = 0; axis < 3; ++axis) {
      region.lo[axis] = std::max(region.lo[axis], box.lo[axis]);
      region.hi[axis] = std::min(region.hi[axis], box.hi[axis]);
    }
    mask.assign(static_cast<std::size_t>(region.count()), 0);
    for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = owners[box.index(region.cell_at(i))] == w;
    for (int axis = 0; axis < 3; ++axis) dilate_axis(mask, region, axis, reach);
    std::fill(seen.begin(), seen.end(), 0);
    for (std::size_t i = 0; i < mask.size(); ++i)
      if (mask[i]) seen[static_cast<std::size_t>(owners[box.index(region.cell_at(i))])] = 1;
    for (WorldId v = 0; v < world_count; ++v)
      if (v != w && seen[static_cast<std::size_t>(v)]) out[static_cast<std::size_t>(w)].push_back(v);
  }
  return out;
}

}  // namespace soda::detail
