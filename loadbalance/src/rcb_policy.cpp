#include "rcb_policy.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "assignment.h"

namespace soda::detail {
namespace {

struct Bisection {
  const CellBox& box;
  const std::vector<double>& weights;
  std::vector<int>& parts;

  // Weight of the slices of `region` along `axis`, lowest first.
  std::vector<double> slices(const CellBox& region, int axis) const {
    std::vector<double> out(static_cast<std::size_t>(region.extent(axis)), 0.0);
    for (int x = region.lo.x; x <= region.hi.x; ++x)
      for (int y = region.lo.y; y <= region.hi.y; ++y)
        for (int z = region.lo.z; z <= region.hi.z; ++z) {
          const CellCoord c{x, y, z};
          out[static_cast<std::size_t>(c[axis] - region.lo[axis])] += weights[box.index(c)];
        }
    return out;
  }

  void run(const CellBox& region, int first, int k) {
    if (k == 1) {
      for (int x = region.lo.x; x <= region.hi.x; ++x)
        for (int y = region.lo.y; y <= region.hi.y; ++y)
          for (int z = region.lo.z; z <= region.hi.z; ++z) parts[box.index({x, y, z})] = first;
      return;
    }
    const int k_low = k / 2;
    std::array<int, 3> axes{0, 1, 2};
    std::stable_sort(axes.begin(), axes.end(), [&](int a, int b) { return region.extent(a) > region.extent(b); });
    for (int axis : axes)
      if (region.extent(axis) > 1 && split(region, axis, first, k, k_low, true)) return;
    // No axis splits with floor(k/2) and ceil(k/2) worlds each holding a
    // cell: split the longest axis by weight and shift the counts so each
    // side keeps a cell per world (a region holds at least k cells).
    split(region, axes[0], first, k, k_low, false);
  }

  // Splits region on axis at the boundary nearest the weight share of k_low
  // worlds; with `strict`, only at boundaries leaving a cell per world on
  // each side (false if there is none), else at the best boundary with
  // k_low shifted to fit.
  bool split(const CellBox& region, int axis, int first, int k, int k_low, bool strict) {
    const std::int64_t n = region.extent(axis);
    const std::int64_t cross = region.count() / n;  // cells per slice
    const std::vector<double> w = slices(region, axis);
    double total = 0;
    for (double v : w) total += v;
    const double target = total * k_low / k;
    std::int64_t best = -1;  // slices [0, best) low, [best, n) high
    double best_error = 0, below = 0;
    for (std::int64_t b = 1; b < n; ++b) {
      below += w[static_cast<std::size_t>(b - 1)];
      if (strict && (b * cross < k_low || (n - b) * cross < k - k_low)) continue;
      const double error = std::abs(below - target);
      if (best < 0 || error < best_error) {
        best = b;
        best_error = error;
      }
    }
    if (best < 0) return false;
    const std::int64_t low_cells = best * cross, high_cells = (n - best) * cross;
    k_low = static_cast<int>(std::clamp<std::int64_t>(k_low, std::max<std::int64_t>(1, k - high_cells),
                                                      std::min<std::int64_t>(k - 1, low_cells)));
    CellBox low = region, high = region;
    low.hi[axis] = region.lo[axis] + static_cast<int>(best) - 1;
    high.lo[axis] = region.lo[axis] + static_cast<int>(best);
    run(low, first, k_low);
    run(high, first + k_low, k - k_low);
    return true;
  }
};

}  // namespace

std::vector<int> bisect(const CellBox& box, const std::vector<double>& weights, int k) {
  std::vector<int> parts(static_cast<std::size_t>(box.count()), 0);
  Bisection{box, weights, parts}.run(box, 0, k);
  return parts;
}

std::vector<CellMove> RcbPolicy::decide(const LoadView& view) {
  monitor_.update(view);
  const int k = static_cast<int>(view.worlds.size());
  if (view.map == nullptr || k < 2 || view.map->world_count() != k) return {};
  const std::vector<LoadClass>& cls = monitor_.classes();
  if (std::none_of(cls.begin(), cls.end(), [](LoadClass c) { return c == LoadClass::Overloaded; })) return {};
  const TerritoryMap& map = *view.map;
  const CellBox& box = map.box();
  if (box.count() < k) return {};
  const std::size_t n = static_cast<std::size_t>(box.count());

  // 1. Cell weights: model cost, and a floor for cells with no body.
  const CostModel& model = monitor_.model();
  std::vector<double> cost(n, 0.0), bodies(n, 0.0);
  double total = 0;
  for (const CellLoad& cell : view.cells) {
    const std::size_t i = box.index(box.clamp(cell.cell));
    const double c = model.cell_cost(cell);
    cost[i] += c;
    bodies[i] += cell.bodies;
    total += c;
  }
  const double floor = total > 0 ? kEmptyCellShare * total / static_cast<double>(n) : 1.0;
  std::vector<double> weights(n);
  for (std::size_t i = 0; i < n; ++i) weights[i] = cost[i] > 0 ? cost[i] : floor;

  // 2. Bisection; 3. relabelling by the largest overlap.
  const std::vector<int> parts = bisect(box, weights, k);
  std::vector<std::vector<double>> overlap(static_cast<std::size_t>(k), std::vector<double>(static_cast<std::size_t>(k), 0.0));
  const std::span<const WorldId> owners = map.owners();
  for (std::size_t i = 0; i < n; ++i)
    overlap[static_cast<std::size_t>(parts[i])][static_cast<std::size_t>(owners[i])] += 1.0 + bodies[i];
  const std::vector<int> label = max_weight_assignment(overlap);

  // 4. Taken only if the model predicts a real gain.
  std::vector<double> before(static_cast<std::size_t>(k), model.coefficients().overhead), after = before;
  for (std::size_t i = 0; i < n; ++i) {
    before[static_cast<std::size_t>(owners[i])] += cost[i];
    after[static_cast<std::size_t>(label[static_cast<std::size_t>(parts[i])])] += cost[i];
  }
  const double max_before = *std::max_element(before.begin(), before.end());
  const double max_after = *std::max_element(after.begin(), after.end());
  if (!(max_after < (1.0 - kRcbMinGain) * max_before)) return {};

  std::vector<CellMove> moves;
  for (std::size_t i = 0; i < n; ++i) {
    const WorldId to = label[static_cast<std::size_t>(parts[i])];
    if (to != owners[i]) moves.push_back({box.cell_at(i), owners[i], to});
  }
  return moves;
}

}  // namespace soda::detail
