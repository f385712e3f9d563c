// loadbalance/ — the load-balancing policy interface (docs/loadbalance.md).
//
// A policy looks at what the worlds measured over the last balance period
// (LoadView) and answers which cells change owner (CellMove) at the balance
// step, a scene step at which every world stands. The partitioned runtime
// applies the moves exactly (the bodies of a ceded cell migrate with their
// contact state), so a policy decides speed, never physics: results are
// bit-identical under every policy (tests/runtime/balance_test.cpp).
//
// Contract of decide():
//  1. a pure function of the view and of the policy's own state (smoothing,
//     a seeded random generator): never of wall time, addresses or hash
//     order; the same run gives the same decisions (experiments repeat);
//  2. every move names a box cell of view.map whose owner is `from`, at most
//     one move per cell, worlds in [0, world_count);
//  3. a world may be left without cells (famine, the thesis' §3.3.5): the
//     runtime keeps running it with no bodies; policies that avoid it say so.
//
// Thread safety: a policy is called by one thread at a time (the runtime's
// driving thread, between periods).
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda {

class LoadMonitor;

/// What one world measured over the last balance period. Times in seconds,
/// per internal step (means over the period's steps).
struct WorldLoad {
  WorldId world = 0;
  std::int64_t steps = 0;       // internal steps of the period measured
  double busy = 0;              // thread CPU time stepping the world (restores and re-runs included)
  double wait = 0;              // wall time blocked on neighbours' messages
  double lead = 0;              // mean internal steps ahead of the commit horizon
  std::int64_t bodies = 0;      // dynamic bodies owned at the balance step
  std::int64_t awake_bodies = 0;
  std::int64_t contact_pairs = 0;  // manifolds with points held at the balance step
  /// Awake bodies times the triangles of level geometry within reach of
  /// their home cells (CellLoad::triangles), summed over the world's cells.
  std::int64_t body_triangles = 0;
  std::int64_t islands = 0;     // islands solved in the period's last step (merged ones counted once, at their root)
  std::int64_t cells = 0;       // box cells owned
};

/// What one box cell holds at the balance step (cells holding no body are
/// left out). A body outside the map's box counts in the box cell its home
/// cell clamps to (TerritoryMap invariant 2).
struct CellLoad {
  CellCoord cell;
  WorldId owner = kNoWorld;
  std::int32_t bodies = 0;         // dynamic bodies whose home cell this is
  std::int32_t awake_bodies = 0;   // ... of them awake
  std::int32_t contact_pairs = 0;  // manifolds with points whose key body's home cell this is
  /// Triangles of static meshes and heightfields within the cell's reach
  /// (soda/grid/cell_triangles.h): what each of its awake bodies may test.
  /// 0 when BalanceOptions::triangle_cost is off.
  std::int32_t triangles = 0;
};

/// Everything a policy may look at.
struct LoadView {
  std::int64_t step = 0;           // scene step the moves take effect at
  const TerritoryMap* map = nullptr;  // the map in force until then (reach included)
  std::vector<WorldLoad> worlds;   // one per world, by id
  std::vector<CellLoad> cells;     // canonical cell order (lexicographic x, y, z)
};

/// One cell given from one world to another at the balance step.
struct CellMove {
  CellCoord cell;
  WorldId from = kNoWorld;
  WorldId to = kNoWorld;
  friend bool operator==(const CellMove&, const CellMove&) = default;
};

/// Options of every policy, with their documented defaults
/// (docs/loadbalance.md says why each default).
struct BalanceOptions {
  /// none | diffusive | rcb | churn.
  std::string policy = "none";
  /// Scene steps between balance steps (a balance step is a step boundary
  /// every world reaches before any goes on). >= 1.
  int period = 20;
  /// Weight of the newest period in the smoothed load (exponential moving
  /// average), in (0, 1]: 1 keeps no history.
  double smoothing = 0.5;
  /// A world is overloaded above overload x mean smoothed busy time, and
  /// underloaded below underload x mean.
  double overload = 1.15;
  double underload = 0.85;
  /// Most cells one world gives away at one balance step (diffusive, churn).
  /// diffusive counts loaded cells only: the empty cells that go with them
  /// (CessionPlanner::tidy) are free. 64, not the thesis' few: a moving load
  /// brings a front of cells into a world each period, and with two worlds
  /// half a block's footprint must change hands (docs/loadbalance.md
  /// "Options and defaults": drift 900 on 2 worlds, mean imbalance 1.52 at
  /// 16 cells, 1.14 at 64, 1.13 at 256; hotspot 400 on 8 worlds, period 10,
  /// 1.49 at 16, 1.42 at 64).
  int max_cells_per_move = 64;
  /// Seed of tie-breaks and of churn's choices.
  std::uint64_t seed = 1;
  /// The runtime counts the triangles of level geometry within each cell's
  /// reach (CellLoad::triangles, WorldLoad::body_triangles), which the cost
  /// model charges per awake body (docs/loadbalance.md, "Triangles"); off:
  /// both stay 0 and cells cost their bodies and pairs only.
  bool triangle_cost = true;
};

/// Bad balance options or an unknown policy name (the message names the
/// option and the accepted values).
class BalanceError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// A load-balancing policy (contract above).
class BalancePolicy {
 public:
  virtual ~BalancePolicy() = default;
  /// The name given to make_balance_policy.
  virtual const char* name() const = 0;
  /// The cells that change owner at view.step; empty: none.
  virtual std::vector<CellMove> decide(const LoadView& view) = 0;
  /// The monitor a measuring policy decided on (its loads, classes, cost
  /// model and how well the model predicted the last period:
  /// load_monitor.h); nullptr for a policy that measures nothing (churn).
  /// Valid while the policy lives.
  virtual const LoadMonitor* monitor() const { return nullptr; }
};

/// The policy named by options.policy. Throws BalanceError for an unknown
/// name or options out of range.
std::unique_ptr<BalancePolicy> make_balance_policy(const BalanceOptions& options);

}  // namespace soda
