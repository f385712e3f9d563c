// runtime/ — internal: the knobs of a PartitionedWorld that only tests set
// (they include runtime/src). They ride in PartitionedOptions::testing (and
// SimulationConfig::testing), an opaque handle the public headers only
// declare, so the public options carry no test-only field and an installed
// tree has no way to set them.
//
//   soda::PartitionedOptions o;
//   soda::detail::edit_testing_hooks(o).fuzz_seed = 7;
//   soda::PartitionedWorld world(scene, map, o);
//
// Thread safety: the hooks are read once, when the PartitionedWorld builds
// its worlds; set them before constructing it.
#pragma once

#include <cstdint>
#include <memory>

#include "soda/runtime/partitioned_world.h"
#include "soda/scene/scene.h"

namespace soda::detail {

/// A blow-up injected once per PartitionedWorld: at the end of scene step
/// `step` (before the watchdog's check) body `body`'s linear velocity
/// becomes NaN. step < 1: none.
struct InjectedFault {
  std::int64_t step = 0;
  BodyId body = 0;
};

struct TestingHooks {
  /// The watchdog's tests: a fault to detect, stop on or heal.
  InjectedFault inject_fault = {};
  /// Fuzzing: > 0 pauses every message send and every stage of every world
  /// at random (seeded: transport.h, fuzz_pause), so that threads interleave
  /// and messages arrive in unusual orders. Results must not change. 0: off.
  std::uint64_t fuzz_seed = 0;
  /// Every world involved in a border island solves it itself (identical
  /// results, no Results messages) instead of its root solving it once and
  /// relaying the result down the island's tree (docs/partitioned-step.md):
  /// the protocol variant the decomposition tests compare with.
  bool solve_everywhere = false;
  /// Speculation: islands a re-run replays (takes from the run it repeats
  /// instead of solving: docs/rollback.md) are solved anyway and their
  /// result compared with the replayed one, bit for bit; a difference
  /// throws std::logic_error. Costs what replaying saves.
  bool verify_replay = false;
};

/// The hooks `options` (PartitionedOptions or SimulationConfig) carries
/// (all off if none).
template <class Options>
const TestingHooks& testing_hooks_of(const Options& options) {
  static const TestingHooks none;
  return options.testing ? *options.testing : none;
}

/// The hooks of `options`, to set: a copy of what it carried, now its own
/// (copies of `options` made before are not affected). The reference is
/// valid while `options.testing` is not reassigned.
template <class Options>
TestingHooks& edit_testing_hooks(Options& options) {
  auto hooks = std::make_shared<TestingHooks>(testing_hooks_of(options));
  options.testing = hooks;
  return *hooks;
}

}  // namespace soda::detail
