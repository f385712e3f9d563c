// diffusive: the thesis' cession between neighbours (§3.3.3–§3.3.5;
// docs/loadbalance.md, "Policies"). At each balance step:
//  1. overloaded worlds give, most loaded first: recipients among their
//     neighbours by priority (lowest smoothed load, then fewest neighbours
//     and smallest territory, then a seeded tie-break); cells among their
//     own cells face-adjacent to the recipient, one at a time, by a score of
//     estimated cost delivered, perimeter of both territories after the move
//     and foreign neighbours, until the excess over the mean is given;
//  2. underloaded worlds ask: each takes from its most loaded neighbour that
//     is above the mean and not underloaded (the thesis' condition);
//  3. famine (§3.3.5): an underloaded world that obtained nothing from its
//     neighbours (none above the mean, or none with a cell it could give)
//     for kFaminePeriods balance steps running (kDesertFaminePeriods when
//     all its neighbours are underloaded too) while some world is
//     overloaded bestows all its cells on its neighbours and takes over a
//     connected piece of the most loaded world's territory — the one move
//     between worlds that need not be neighbours (the thesis' request "to
//     all worlds"), at most one per balance step.
// Invariants of every decision:
//  a. a world gives at most CessionPlanner::cap() loaded cells per balance
//     step — max_cells_per_move, more the larger its excess (the
//     famine bestowal excepted: it gives everything it has, and the world
//     receives at least one cell in the same step, so no world is left
//     without cells by this policy);
//  b. a cell given in step 1 or 2 is face-adjacent to the recipient's
//     territory and its removal cannot split the giver's (OwnerGrid::removable),
//     and a giver keeps at least one cell;
//  c. a cell is given only if the giver's estimated load minus its cost stays
//     at or above the recipient's plus its cost: a move never reverses an
//     imbalance, so cells do not go back and forth;
//  d. a world gives at most once per balance step; it may also receive, in
//     the cascade only: an overloaded world whose neighbours were as loaded
//     as itself gives to one that has just given on (diffusive_policy.cpp).
#pragma once

#include <vector>

#include "soda/loadbalance/load_monitor.h"
#include "soda/loadbalance/policy.h"

namespace soda::detail {

/// Balance steps an underloaded world must have had nothing to ask from
/// its neighbours before it relocates (famine): three periods (60 steps at
/// the default period) so that a neighbour about to become loaded — a load
/// crossing towards it — is waited for, and a transient dip does not move a
/// whole territory.
inline constexpr int kFaminePeriods = 3;
/// The same for a world in a desert (every neighbour underloaded too): no
/// load can come through its neighbours within a period, so there is
/// nothing to wait for.
inline constexpr int kDesertFaminePeriods = 1;

class DiffusivePolicy final : public BalancePolicy {
 public:
  explicit DiffusivePolicy(const BalanceOptions& options);
  const char* name() const override { return "diffusive"; }
  std::vector<CellMove> decide(const LoadView& view) override;
  /// The loads, classes and cost model this policy decided on.
  const LoadMonitor* monitor() const override { return &monitor_; }

 private:
  class Planner;
  BalanceOptions options_;
  LoadMonitor monitor_;
  std::vector<int> famine_periods_;  // per world: balance steps in famine running
};

}  // namespace soda::detail
