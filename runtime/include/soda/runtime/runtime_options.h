// runtime/ — the knobs every way of running a scene shares. This header:
// RuntimeOptions, declared once and embedded as the member `runtime` by
// PartitionedOptions (partitioned_world.h), SimulationConfig (simulation.h)
// and RunConfig (run.h); each of those passes it on whole, never field by
// field, so a new knob is one field here.
//
//   soda::Simulation sim(scene, {.territories = 4, .runtime = {.anticipation = 8}});
//   soda::RunConfig config;
//   config.runtime.parking = false;
//
// Why a member and not a base class: C++20 designated initializers name
// direct members only, and GCC's -Wextra warns at every `{.territories = 4}`
// of an aggregate with a base (the base is an initializer left out), in an
// embedder's code too.
//
// Invariants:
//  1. no knob changes a result: the state hash is the same for every value
//     (the watchdog and validation may stop a run, never change its steps);
//  2. each knob means the same in the three configs; where one of them does
//     not support a value it refuses it with std::invalid_argument naming the
//     knob (a Simulation: the watchdog's Heal, load balancing).
#pragma once

#include "soda/loadbalance/policy.h"
#include "soda/worlds/watchdog.h"

namespace soda {

struct RuntimeOptions {
  /// Speculation (docs/rollback.md): a world may run up to `anticipation`
  /// scene steps past the commit horizon, betting that a neighbour it sent
  /// no ghosts at a step sends it no ghosts and no migrants at that step; a
  /// lost bet, or a neighbour's message that differs from the one it used,
  /// rolls the world back to that step (it keeps its state at every step
  /// from the commit horizon on). Results are bit-identical to anticipation
  /// 0 (lockstep with the neighbours, no bets). With one territory there is
  /// no neighbour to bet on (no effect). Not with the watchdog's Heal. >= 0.
  int anticipation = 0;
  /// What a rollback makes the neighbours do (speculation only).
  enum class Rollback {
    /// Rollback and Propagate: a neighbour re-runs only if a message it used
    /// changes (re-sent messages are compared with the ones used; merged
    /// islands are re-merged), so a rollback stays where the change is.
    Propagate,
    /// Discard and recompute (the baseline to measure against): every
    /// neighbour that used any message of a rolled-back step rolls back too.
    Recompute,
  };
  Rollback rollback = Rollback::Propagate;
  /// Speculation: a world keeps its state every `checkpoint_every` internal
  /// steps; a rollback restores the checkpoint at or before the step and
  /// re-runs the rest. 1: every step, so a rollback re-runs only what
  /// changed and stays local more often (a re-run over a step with merged
  /// islands is a rollback of every world), and re-run steps replay the
  /// islands that come out unchanged instead of solving them (with a larger
  /// value only the step a rollback interrupted is replayed;
  /// docs/rollback.md). A state every step costs about 12 % of per-world
  /// CPU on alternating-load. >= 1.
  int checkpoint_every = 8;
  /// Speculation: also bet on a neighbour whose newest ghosts to arrive were
  /// not empty. Off (the default), a world waits for such a neighbour's
  /// messages: a border that has just become busy mostly stays busy, and
  /// betting on each following step lost a bet and re-ran the world each
  /// time (falling-cubes 100 over a 1x8 strip with a slow world 0: 1078
  /// rollbacks eager, 8 not; docs/rollback.md). On: as many bets and
  /// rollbacks as possible (tests of the rollback machinery use it).
  bool eager_bets = false;
  /// Idle territories (docs/skip.md): a world whose owned bodies are all
  /// settled asleep (or that has none), that holds no ghost and sent none,
  /// skips its Bullet stages at a step no neighbour sends it a ghost for:
  /// it sends its (empty) Ghosts and Migrants and advances its clock. A
  /// ghost arriving wakes it for that step (under speculation, a late one
  /// through the usual rollback). Exact (tests/runtime/idle_territories_test.cpp).
  /// False: every world runs every stage of every step (`--no-idle-skip`).
  bool idle_territories = true;
  /// Parking (docs/skip.md): each world parks its settled sleeping islands
  /// that lie inside its own cells outside its Bullet world
  /// (TerritoryWorld::set_parking; with one territory the canonical world's,
  /// CanonicalWorld::set_parking); a parked island comes back when an
  /// active body or ghost touches it, or an input names one of its bodies.
  /// Exact (tests/runtime/parking_test.cpp). False: sleepers stay in Bullet
  /// (`--no-parking`). No effect on stock Bullet.
  bool parking = true;
  /// Reach (docs/partitioned-step.md, "Reach beyond adjacent cells"): the
  /// worlds' neighbourhoods are widened to every world owning a cell within
  /// reach_cells(scene, cell size, speed) cells of their territory
  /// (worlds/reach.h), so that the halo and the migration of a body up to
  /// this speed (m/s) only reach neighbours. 0: scene_reach_speed(scene)
  /// (its fastest initial speed plus a fall through its height); slow scenes
  /// keep adjacent worlds only. A body that outruns it stops the run with a
  /// PartitionError naming the body, its speed and the speed to set here.
  /// >= 0.
  double reach_speed = 0;
  /// Metres: the bounding-sphere diameter of the largest body an input may
  /// add (the reach is sized for it too: reach.h). 0: the largest of the
  /// scene and of the inputs known before the run. A larger added body is
  /// refused, naming its size and the largest the run takes. >= 0.
  double added_extent = 0;
  /// Threads that solve the colours of a large island (docs/coloured-solve.md):
  /// one pool of solver_threads - 1 helper threads shared by every world,
  /// joined by the thread of the world solving; a world that finds it busy
  /// solves alone. 1: no pool (unless guests, below). >= 1.
  int solver_threads = 1;
  /// Guests of that pool (SolverPool::serve): with a thread per world, the
  /// thread of a world waiting for a message (a merged island's root
  /// solving it, say) takes tasks of the pool's jobs meanwhile, at most this
  /// many at once; their time inside its jobs counts as their own world's
  /// work (stage solve). -1: automatic, the cores a run leaves free: none if
  /// K > hardware threads (a waiting world's core runs another world), else
  /// min(K - 1, hardware threads - solver_threads), at least 0. 0: none.
  /// Other schedules and ranks: none.
  int solver_guests = -1;
  /// After every step each world checks its bodies and contacts
  /// (watchdog.h). Heal: each world keeps its state at every step boundary
  /// back to the commit horizon (the cost of a snapshot per step), and a bad
  /// step is rolled back and re-simulated with substeps (docs/watchdog.md).
  WatchdogConfig watchdog = {};
  /// Check ownership and pair holders after every step (slow); a broken
  /// invariant throws ValidationError naming the step, bodies and worlds.
  bool validate = false;
  /// Pin the stepping threads to cores: a thread per world, world i's
  /// thread; a pool, worker i; on CPU (i mod the CPUs this process may use).
  /// A failure to pin is a logged warning. One thread for every world runs
  /// on the caller's thread and never pins it.
  bool pin = false;
  /// Load balancing (docs/loadbalance.md): every balance.period scene steps
  /// every world stops at that step (the *balance step*: nothing is
  /// speculated beyond it), the policy sees what the worlds measured over
  /// the period (LoadView), the cells it names go to their new owners and
  /// the worlds the moves change are rebuilt for the new map from the whole
  /// scene's state there. Bit-identical under every policy; speed is not.
  /// Policy "none" (the default) has no balance steps at all. Checked by
  /// make_balance_policy: bad values throw BalanceError (a
  /// std::invalid_argument).
  BalanceOptions balance = {};
};

}  // namespace soda
