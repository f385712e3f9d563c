// Internal: the `churn` balance policy (docs/loadbalance.md, "churn"). It
// balances nothing: every balance step it gives a few seeded-random cells to
// other worlds, so that the runtime's cession machinery (cells and their
// bodies changing hands, neighbour sets changing, famine) is exercised by
// every test and experiment that names it.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "soda/loadbalance/policy.h"

namespace soda::detail {

/// Each balance step: up to max_cells_per_move cells, drawn uniformly among
/// the cells holding bodies (view.cells) while there are any left, then
/// among every box cell; each goes to a world drawn uniformly among its
/// owner's neighbours (in view.map, so within its reach), or, one draw in
/// kAnyWorldOneIn or when the owner has no neighbour, among every other
/// world (a territory that jumps: new, non-adjacent neighbours). With one
/// world: no move. A pure function of the views and the seed; draws are
/// explicit bounded draws from a mt19937_64, the same on every platform.
class ChurnPolicy final : public BalancePolicy {
 public:
  /// One draw in this many sends a cell to any other world rather than to a
  /// neighbour of its owner: often enough that a short test meets it, rare
  /// enough that territories mostly stay near their neighbours.
  static constexpr std::uint64_t kAnyWorldOneIn = 4;

  explicit ChurnPolicy(const BalanceOptions& options);
  const char* name() const override { return "churn"; }
  std::vector<CellMove> decide(const LoadView& view) override;

 private:
  std::uint64_t draw(std::uint64_t bound);  // uniform-ish in [0, bound), bound >= 1

  int cells_per_step_;
  std::mt19937_64 random_;
};

}  // namespace soda::detail
