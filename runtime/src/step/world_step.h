// Internal: what one world's step is in the middle of — the state the step
// (world_process.h) runs and speculation (speculation.h) rewinds. Plain data
// with one reset routine, begin_again(), for every way back in time.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <tuple>
#include <vector>

#include "step/island_merge.h"
#include "soda/rollback/transform_buffer.h"
#include "soda/runtime/messages.h"
#include "soda/worlds/territory_world.h"

namespace soda {

/// Where a world's step can wait (world_process.h, the state machine).
enum class StepPhase { Predict, AwaitGhosts, AwaitGlue, Merging, AwaitMigrants, Publish };

/// A neighbour's message in the inbox: (kind, step, from).
using MessageKey = std::tuple<int, std::int64_t, WorldId>;
inline MessageKey message_key(MessageKind kind, std::int64_t step, WorldId from) {
  return MessageKey{static_cast<int>(kind), step, from};
}

struct WorldStep {
  // A border island complete here, by smallest body id, until its result is
  // kept and passed on.
  struct Island {
    WorldId root = kNoWorld;
    WorldId parent = kNoWorld;
    std::vector<WorldId> children;
    std::vector<Fragment> data;  // fragments with data of this subtree
    std::size_t gathers_missing = 0;
  };

  TerritoryWorld* world = nullptr;  // replaced when the world is rebuilt (a rollback)
  std::int64_t step = 0;            // internal step in progress (= steps done)
  StepPhase phase = StepPhase::Predict;
  bool idle = false;                // an idle step: no Bullet stage unless a ghost arrives (docs/skip.md)
  std::map<MessageKey, Message> inbox;
  std::map<std::int64_t, std::vector<Message>> fragments;  // Fragments, Gather, Results, by step
  IslandMerger merger;
  std::map<BodyId, Island> islands;
  std::map<BodyId, std::vector<Fragment>> early_gathers;  // for islands not complete here yet
  // Publish (under a Simulation).
  std::optional<TransformEntry<btScalar>> pending;  // the entry waiting for room
  std::deque<TransformEntry<btScalar>> backlog;     // entries of steps a rejoin took back, first
  bool publish_current = false;                     // the entry of the step just ended is due
  std::int64_t next_publish = 0;                    // scene steps below it are published (a re-run skips them)
  std::int64_t room_wait_since_ns = 0;              // when it first found the buffer full

  /// The one reset routine: the step starts again at internal step `at`
  /// (its Predict) in `w`, forgetting the step in progress — its merge and
  /// its unpublished entries. The inbox and the merge messages of later
  /// steps stay (the caller decides which of them are void).
  void begin_again(TerritoryWorld& w, std::int64_t at) {
    world = &w;
    step = at;
    phase = StepPhase::Predict;
    idle = false;
    merger = IslandMerger{};
    islands.clear();
    early_gathers.clear();
    pending.reset();
    backlog.clear();
    publish_current = false;
    room_wait_since_ns = 0;
  }
};

}  // namespace soda
