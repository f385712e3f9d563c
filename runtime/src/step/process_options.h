// Internal: what a world process (world_process.h) is given besides its
// world and its neighbours: the options that make it safe (watchdog,
// speculation, test knobs) and, under a Simulation, where its output goes.
// At namespace level so that the speculation component (speculation.h) can
// name them; PartitionedWorld::Process::Safety and ::Output are these.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>

#include "soda/rollback/commit_horizon.h"
#include "step/input_queue.h"
#include "soda/rollback/rollback_board.h"
#include "soda/rollback/transform_buffer.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/transport.h"
#include "driver/testing_hooks.h"

namespace soda {

class RunControl;

/// The watchdog, the injected fault and the rollback ring (options of the
/// PartitionedWorld; pointers outlive the process).
struct ProcessSafety {
  const WatchdogConfig* watchdog = nullptr;
  detail::InjectedFault fault = {};
  std::atomic<bool>* fault_fired = nullptr;
  CommitHorizon* horizon = nullptr;  // reported at every scene step boundary
  bool keep_states = false;          // keep the world's state at every boundary >= GVT
  FuzzRandom* fuzz = nullptr;        // fuzzing: a random pause before every stage
  int anticipation = 0;              // speculation: internal steps past the horizon; 0: off
  int checkpoint_every = 1;          // speculation: internal steps between kept states
  bool recompute = false;            // speculation: discard and recompute instead of propagate
  bool eager_bets = false;           // speculation: bet on neighbours whose newest ghosts were not empty
  bool verify_replay = false;        // speculation: solve replayed islands anyway and compare
  bool skip_idle = true;             // idle territories: skip the steps that cannot change this world
  RollbackBoard* board = nullptr;    // speculation: rollbacks of every world
  /// Speculation: replaces this world by one rebuilt from its own part of
  /// the state (as kept) at an internal step boundary; returns it.
  std::function<TerritoryWorld&(const WorldSnapshot&, std::int64_t)> rebuild;
};

/// What a Simulation adds: the step limit comes from `control` (asked
/// before each step begins); after each scene step `after_step` runs and
/// the poses go to `buffer` as (scene step, scene step * dt).
struct ProcessOutput {
  RunControl* control = nullptr;
  TransformBuffer<btScalar>* buffer = nullptr;
  double dt = 0;
  std::function<void(WorldId, std::int64_t)> after_step;
  InputQueue* inputs = nullptr;  // user inputs, applied at each scene step boundary
  /// A rollback pending for this world (RunControl::take_rewind): on the
  /// world's own thread, rebuild the world from the state and rewind().
  std::function<void(const WorldSnapshot&)> rewind;
  /// Each entry also carries the contacts of the pairs this world reports
  /// (reported_contacts): SimulationConfig::contact_events.
  bool contacts = false;
};

/// The entry of scene step `scene_step` for a transform buffer: the poses
/// of `states` (a world's owned bodies), at time scene_step * dt.
TransformEntry<btScalar> transform_entry(std::int64_t scene_step, double dt, const std::vector<BodyState>& states);

/// The contacts `world` reports at a step boundary: of `manifolds` (its
/// kept_contact_state() there, ascending by pair), those with points whose
/// key body is in `owned` (the bodies it owns there, ascending) — every pair
/// of the scene in exactly one world, whatever the partition. Ascending by
/// pair.
std::vector<PairContact<btScalar>> reported_contacts(const TerritoryWorld& world,
                                                     const std::vector<ManifoldState>& manifolds,
                                                     const std::vector<BodyId>& owned);

}  // namespace soda
