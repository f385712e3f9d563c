// Recursive coordinate bisection (spec "rcb"), see partition.h.
#include <algorithm>
#include <array>
#include <cstdlib>

#include "partition_detail.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

std::int64_t ceil_div(std::int64_t a, std::int64_t b) { return (a + b - 1) / b; }

// A dynamic body's home cell and its weight (detail::dynamic_weights).
struct WeightedCell {
  CellCoord cell;
  std::int64_t weight = 0;
};

struct Bisection {
  const CellBox& box;
  std::vector<WorldId>& owners;
  WorldId next = 0;

  void fill(const CellBox& region) {
    for (int x = region.lo.x; x <= region.hi.x; ++x)
      for (int y = region.lo.y; y <= region.hi.y; ++y)
        for (int z = region.lo.z; z <= region.hi.z; ++z) owners[box.index({x, y, z})] = next;
    ++next;
  }

  // Precondition: region.count() >= k >= 1; pts are the body cells in region.
  void split(const CellBox& region, const std::vector<WeightedCell>& pts, int k) {
    if (k == 1) {
      fill(region);
      return;
    }
    const std::int64_t k1 = k / 2;
    const std::int64_t cells = region.count();
    std::int64_t n = 0;
    for (const WeightedCell& p : pts) n += p.weight;
    std::array<int, 3> axes{0, 1, 2};
    std::stable_sort(axes.begin(), axes.end(),
                     [&](int a, int b) { return region.extent(a) > region.extent(b); });
    // First axis (longest first) on which both sides can hold their share
    // of territories with at least one cell each.
    int axis = -1;
    std::int64_t m_min = 0;
    std::int64_t m_max = 0;
    for (int a : axes) {
      const std::int64_t len = region.extent(a);
      if (len < 2) continue;
      const std::int64_t slice = cells / len;
      const std::int64_t lo = std::max<std::int64_t>(1, ceil_div(k1, slice));
      const std::int64_t hi = std::min(len - 1, len - ceil_div(k - k1, slice));
      if (lo <= hi) {
        axis = a;
        m_min = lo;
        m_max = hi;
        break;
      }
    }
    const bool exact = axis >= 0;
    if (!exact) {  // no axis fits floor(K/2) | ceil(K/2): shift the counts below
      axis = axes[0];
      m_min = 1;
      m_max = region.extent(axis) - 1;
    }
    const std::int64_t len = region.extent(axis);
    const std::int64_t slice = cells / len;
    std::vector<std::int64_t> below(static_cast<std::size_t>(len) + 1, 0);
    for (const WeightedCell& p : pts) below[static_cast<std::size_t>(p.cell[axis] - region.lo[axis]) + 1] += p.weight;
    for (std::size_t i = 1; i < below.size(); ++i) below[i] += below[i - 1];
    // Boundary after m slices: body weight below nearest n * k1 / k, then cells
    // below nearest cells * k1 / k, then the lowest m. Exact integers.
    std::int64_t best = m_min;
    auto key = [&](std::int64_t m) {
      return std::array<std::int64_t, 2>{
          std::llabs(below[static_cast<std::size_t>(m)] * k - n * k1),
          std::llabs(m * slice * k - cells * k1)};
    };
    for (std::int64_t m = m_min + 1; m <= m_max; ++m)
      if (key(m) < key(best)) best = m;
    std::int64_t k_low = k1;
    if (!exact)
      k_low = std::clamp(k1, std::max<std::int64_t>(1, k - (len - best) * slice),
                         std::min<std::int64_t>(best * slice, k - 1));
    CellBox low = region;
    CellBox high = region;
    low.hi[axis] = region.lo[axis] + static_cast<int>(best) - 1;
    high.lo[axis] = region.lo[axis] + static_cast<int>(best);
    std::vector<WeightedCell> low_pts;
    std::vector<WeightedCell> high_pts;
    for (const WeightedCell& p : pts) (p.cell[axis] <= low.hi[axis] ? low_pts : high_pts).push_back(p);
    split(low, low_pts, static_cast<int>(k_low));
    split(high, high_pts, k - static_cast<int>(k_low));
  }
};

}  // namespace

TerritoryMap partition_rcb(const Scene& scene, int k, const GridOptions& options) {
  const UniformGrid grid = make_grid(scene, options);
  const CellBox box = make_box(scene, grid, options);
  detail::check_world_count(k, box, "rcb");
  const std::vector<Vec3> positions = detail::dynamic_positions(scene);
  const std::vector<std::int64_t> weights = detail::dynamic_weights(scene, grid, box, options.triangle_weight);
  std::vector<WeightedCell> pts;
  for (std::size_t i = 0; i < positions.size(); ++i)
    pts.push_back({box.clamp(grid.cell_of(positions[i])), weights[i]});
  std::vector<WorldId> owners(static_cast<std::size_t>(box.count()), kNoWorld);
  Bisection bisection{box, owners};
  bisection.split(box, pts, k);
  detail::renumber_canonical(owners, k);
  detail::verify_partition(box, owners, k);
  return TerritoryMap(grid, box, std::move(owners), k);
}

}  // namespace soda
