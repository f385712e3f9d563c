// The stages of one world's step, one name each (docs/naming.md): the step's
// state machine (runtime/src/step/world_process.cpp), the TerritoryWorld call it
// makes, the per-stage costs in WorldMetrics and the JSON of `soda run` /
// `soda bench` all use these names.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace soda {

/// In the order a step runs them; the last four are not part of every step.
enum class Stage : std::uint8_t {
  Predict,         // inputs at the boundary, predicted transforms and AABBs
  ExchangeGhosts,  // ghost batches made for and taken from every neighbour
  Collide,         // broadphase and narrowphase over owned bodies and ghosts
  BuildIslands,    // islands built; those no neighbour can touch solved in place
  Glue,            // glue batches made for and taken from neighbours; border fragments
  Merge,           // border islands merged over the fragments' trees, results relayed
  Solve,           // a merged border island solved (at its root)
  Integrate,       // island results kept, transforms integrated, watchdog check
  Migrate,         // bodies handed to and taken from neighbours; ends the step
  Publish,         // (Simulation) the scene step's poses to the transform buffer
  Receive,         // neighbours' messages decoded, sorted, compared with those used
  Checkpoint,      // speculation: states kept, commit horizon reported, old states freed
  Rollback,        // speculation: restores, rejoins, rollbacks of every world taken in
  Idle,            // nothing to run: at the target, or waiting for the commit horizon
};
inline constexpr std::size_t kStageCount = 14;

/// The stage's name (snake_case, as in the JSON): "predict", "exchange_ghosts", ...
const char* stage_name(Stage stage);

/// What one world spent in one stage, summed over its finished internal steps.
struct StageCost {
  /// Thread CPU time of the world's thread in the stage. Summed over the
  /// stages: WorldMetrics::cpu_seconds, exactly (one clock read at every
  /// stage change, each interval given to one stage).
  double cpu_seconds = 0;
  /// Wall time the world waited for what the stage needs (neighbours'
  /// messages, room in the transform buffer, the commit horizon); summed
  /// over the stages: WorldMetrics::blocked_seconds + buffer_blocked_seconds.
  double wait_seconds = 0;
  /// What the stage processed, per stage (docs/naming.md): predict owned
  /// bodies, exchange_ghosts ghosts received, collide contact pairs held,
  /// build_islands islands solved in place, glue border fragments, merge
  /// merged islands taken part in, solve merged islands solved, integrate
  /// owned bodies, migrate bodies in and out, publish entries, receive
  /// messages, checkpoint states kept, rollback restores; summed over steps.
  std::uint64_t items = 0;
  std::uint64_t messages = 0;  // messages sent in the stage
  std::uint64_t bytes = 0;     // their bytes (0 when messages are passed as values)
};

using StageCosts = std::array<StageCost, kStageCount>;

}  // namespace soda
