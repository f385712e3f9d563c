// rcb: global repartition by recursive coordinate bisection of the box cells
// weighted by the cost model (docs/loadbalance.md, "Policies"). The yardstick
// large molecular-dynamics codes use, and the one documented exception to
// neighbour-only messages: it needs every world's load and cells at once, as
// a coordinator would gather them.
//
// At a balance step where some world is overloaded (smoothed load above
// overload x mean):
//  1. every box cell weighs its model cost, a cell with no body a floor of
//     kEmptyCellShare of the mean cell weight (so that empty space is shared
//     out too, and a region of empty cells still splits by size);
//  2. the box is cut recursively: a region for k worlds is split on its
//     longest axis (in cells; ties x, y, z; the next if that axis cannot
//     give each side a cell per world) at the cell boundary that puts the
//     weight share floor(k/2)/k nearest below it (ties: the lower boundary);
//     if no axis can, the longest is split by weight and the world counts
//     shifted so each side keeps a cell per world;
//  3. the parts are relabelled with the current worlds so that the overlap
//     (cells, each weighing 1 + its bodies) is largest (an optimal
//     assignment), so few cells and fewer bodies move;
//  4. the new map is taken only if the model predicts its most loaded world
//     at least kRcbMinGain below the current map's: a repartition that buys
//     little is not worth its migrations.
// Every part is a box of cells: territories stay connected and no world is
// ever left without cells. No limit on the cells moved (max_cells_per_move
// applies to diffusive and churn).
#pragma once

#include <vector>

#include "soda/loadbalance/load_monitor.h"
#include "soda/loadbalance/policy.h"

namespace soda::detail {

/// Weight of a cell with no body, as a share of the mean cell weight: 1 %
/// — empty space is close to free (no body, no pair), but not quite (a
/// territory's cells are its neighbours' border), and a zero weight would
/// let one world take all empty space.
inline constexpr double kEmptyCellShare = 0.01;
/// Least predicted improvement of the most loaded world's cost for a
/// repartition to be taken (5 %: under the model's own error, a new map is
/// noise, not a gain).
inline constexpr double kRcbMinGain = 0.05;

class RcbPolicy final : public BalancePolicy {
 public:
  explicit RcbPolicy(const BalanceOptions& options) : options_(options), monitor_(options) {}
  const char* name() const override { return "rcb"; }
  std::vector<CellMove> decide(const LoadView& view) override;
  const LoadMonitor* monitor() const override { return &monitor_; }

 private:
  BalanceOptions options_;
  LoadMonitor monitor_;
};

/// The bisection alone (steps 1–2): the part, 0 .. k-1, of each box cell in
/// box index order, for weights in box index order. Parts are numbered low
/// side first. Precondition: k <= box.count().
std::vector<int> bisect(const CellBox& box, const std::vector<double>& weights, int k);

}  // namespace soda::detail
