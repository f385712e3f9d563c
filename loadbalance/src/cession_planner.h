// CessionPlanner: plans one balance step's cessions on a working copy of the
// map, keeping every world's estimated load up to date as cells are moved
// (diffusive_policy.h lists the rules it keeps).
//
// Estimated loads start at LoadMonitor::estimated(). A cell's cost in world
// w is kappa_w x the model's cost of the cell, kappa_w = the estimate / the
// model's prediction for w (the monitor's calibration): the model says how
// the cost splits over cells, the measurements how expensive a unit of it
// is on that world's thread.
//
// Thread safety: one thread; lives for one decide() call.
#pragma once

#include <cstdint>
#include <vector>

#include "owner_grid.h"
#include "soda/loadbalance/load_monitor.h"
#include "soda/loadbalance/policy.h"

namespace soda::detail {

/// Weights of the cell score (docs/loadbalance.md, "Policies"): cost
/// delivered (0..1: of what is still wanted, relative to the most an
/// eligible cell delivers) and perimeter change of both territories
/// (-1..1, per face of the six) weighted 1 : 2, so a face of border costs a
/// third of the best cell's gain: among loaded cells the border stays
/// straight. At 0.5 (a cell delivering a third more could bend the border
/// by two faces) the cubes of hotspot, 1.25 m apart on 1.7 m cells (every
/// other row of cells loaded), were given as combs: every body a border
/// body, and the two worlds of `soda lb --scene hotspot --n 400
/// --territories 2 --lb-period 10 --lb-max-cells 256` spent 2.09 s of busy
/// CPU against 0.94 s under `none`; at 2, 1.40 s against 0.90 s, and 8
/// worlds' mean imbalance fell from 1.84 to 1.57 (period 10, 16 cells).
/// Foreign neighbours (0..1 of 26) weigh a quarter, a tie-breaker among
/// similar cells.
inline constexpr double kGainWeight = 1.0;
inline constexpr double kShapeWeight = 2.0;
inline constexpr double kForeignWeight = 0.25;
/// A cell costing less than this share of the mean world load counts as
/// empty (no body, or only sleeping ones: 0.05 µs each against a world's
/// tens to thousands of µs): it is moved only if it shortens the border (a
/// filler that keeps the territories compact) or to advance a border
/// towards the load (cede()).
inline constexpr double kEmptyShare = 1e-3;
/// Weights of the recipient priority (lower is first), on top of the
/// recipient's load over the mean: fewer neighbours and a smaller territory
/// first (§3.3.5), weighted so that they only decide between recipients
/// loaded within a few percent of each other.
inline constexpr double kNeighbourWeight = 0.05;
inline constexpr double kSurfaceWeight = 0.05;
/// Largest factor the cap on loaded cells a world gives per balance step
/// grows by with its excess (CessionPlanner::cap): "the more important the
/// divergence, the faster the load must be rebalanced" (§3.3.2). 8 x the
/// default 64 cells lets a world holding a whole block (drift 900 on 2
/// worlds: load twice the mean at the first balance step) hand half of it
/// over in one step; the bound keeps one step's decision — taken on a cost
/// model that is a rough one — from moving a whole territory.
inline constexpr double kMaxCapFactor = 8.0;

class CessionPlanner {
 public:
  enum class Role { None, Giver, Recipient };

  CessionPlanner(const LoadView& view, const LoadMonitor& monitor, const BalanceOptions& options);

  /// World w's estimated load, s per internal step.
  double load(WorldId w) const { return load_[static_cast<std::size_t>(w)]; }
  /// Every world's estimated load, by id.
  const std::vector<double>& loads() const { return load_; }
  double mean() const { return mean_; }
  Role role(WorldId w) const { return role_[static_cast<std::size_t>(w)]; }
  int given(WorldId w) const { return given_[static_cast<std::size_t>(w)]; }
  /// The most loaded cells w may give in this balance step:
  /// max_cells_per_move times its excess over the mean in units of the
  /// overload threshold's, (load / mean - 1) / (overload - 1), at least 1
  /// and at most kMaxCapFactor, from w's estimated load when the planner
  /// was made. A world just past the threshold gives as before; one at
  /// twice the mean (overload 1.15) gives 6.7 x as many (§3.3.2: the
  /// larger the divergence, the faster it is rebalanced).
  int cap(WorldId w) const { return cap_[static_cast<std::size_t>(w)]; }
  const OwnerGrid& grid() const { return grid_; }

  /// Neighbours of g that may receive from it now (less loaded than g, and
  /// not givers unless `givers_too`: the cascade, diffusive_policy.cpp),
  /// highest priority first.
  std::vector<WorldId> recipients_of(WorldId g, bool givers_too = false) const;
  /// Moves cells of g adjacent to r's territory to r, best first, until
  /// `want` (s per step, in g's units) is given, g's cap is reached or no
  /// cell qualifies. When no loaded cell of g touches r, g's load lies
  /// deeper in its territory: g then gives r the empty cells nearest its
  /// load (fewest face steps through g's cells; then the shorter border),
  /// so that r's border advances towards the load and loaded cells can
  /// follow at the next balance step. Returns the estimated cost given.
  double cede(WorldId g, WorldId r, double want);
  /// Famine: u's cells all go to the worlds around them, and u takes a
  /// connected piece of h's territory worth up to the excess of h over the
  /// mean. Nothing is changed (false) if h has no cell u could take or u's
  /// cells cannot all be handed to a world next to them.
  bool relocate(WorldId u, WorldId h);

  /// Halo tidying, after the cessions: every empty cell (not moved yet)
  /// whose loaded face neighbours all belong to one other world r, no more
  /// loaded than its owner, goes to r, outside the cap and without a role,
  /// if its owner can spare it (rule b). Never towards the more loaded
  /// world: the empty cells ahead of a moving load would go to the world
  /// the load comes from. A body's halo reaches the cells around its own, so an empty cell
  /// next to r's load and no other load belongs with r; left with another
  /// world it makes r's bodies there border bodies for nothing. Without it
  /// diffusive gave only the loaded layer of cells of a ground scene (y = 0)
  /// and kept the empty layers above and below: every body given a border
  /// body (drift 400, 2 worlds, period 20: 101,658 ghost sends against
  /// 2,945 under none, +42 % busy CPU of both worlds).
  void tidy();
  /// The planned moves, in canonical cell order.
  std::vector<CellMove> moves() const;

 private:
  double cell_model_cost(const CellCoord& c) const { return cost_[box_index(c)]; }
  double cost_in(WorldId w, const CellCoord& c) const {
    return kappa_[static_cast<std::size_t>(w)] * cell_model_cost(c);
  }
  std::size_t box_index(const CellCoord& c) const { return grid_.box().index(c); }
  /// True if c may go from g to r now: not moved yet, g's, touching r,
  /// removable (rule b) and not reversing the imbalance (rule c).
  bool eligible(const CellCoord& c, WorldId g, WorldId r) const;
  /// Score of giving c from g to r when `want` is still wanted and the
  /// eligible loaded cells deliver at most `scale` (header comment weights).
  double score(const CellCoord& c, WorldId g, WorldId r, double want, double scale) const;
  /// True if c's cost in w is above kEmptyShare of the mean load.
  bool loaded(WorldId w, const CellCoord& c) const { return cost_in(w, c) > kEmptyShare * mean_; }
  void move(const CellCoord& c, WorldId from, WorldId to);
  /// Face steps from each of g's cells to g's nearest loaded cell, by box
  /// index; -1 for cells not g's or not reached.
  std::vector<int> distance_to_load(WorldId g) const;

  const LoadView& view_;
  BalanceOptions options_;
  OwnerGrid grid_;
  std::vector<double> cost_;   // model cost per box cell (box index)
  std::vector<double> load_;   // estimated load per world
  std::vector<double> kappa_;  // calibration per world
  std::vector<Role> role_;
  std::vector<int> given_;
  std::vector<int> cap_;       // per world: cap()
  std::vector<char> moved_;    // per box cell
  std::vector<CellMove> moves_;
  double mean_ = 0;
};

}  // namespace soda::detail
