// worlds/ — one territory's physics. This header: what a territory world is
// told to replay in its next step (TerritoryWorld::set_replay). Rollback and
// Propagate (docs/rollback.md) re-runs steps a world has run before; an
// island whose contents come out of the re-run unchanged has, its step being
// a pure function of its contents (DESIGN.md §2), the old run's result, and
// is replayed from the old run's states instead of solved. Who keeps those
// states and decides which step replays what is the runtime's speculation;
// how an island is replayed is worlds/src/island_replay.h.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/worlds/body_state.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {

/// The islands a world solved in place in one step (those of build_islands
/// and those no neighbour glued, lone bodies and sleeping islands included),
/// each as its bodies' ids, ascending: island i is ids[begin[i], begin[i+1]).
struct LocalIslands {
  std::vector<BodyId> ids;
  std::vector<std::uint32_t> begin{0};
  std::size_t size() const { return begin.size() - 1; }
  void clear() {
    ids.clear();
    begin.assign(1, 0);
  }
};

/// What the run a re-run repeats did at one step. The pointers must stay
/// valid until the step's integrate() returns.
struct StepReplay {
  const WorldSnapshot* before = nullptr;  // that run's part_snapshot() at the step's start
  const WorldSnapshot* after = nullptr;   // and at its end (see mid_step)
  const LocalIslands* islands = nullptr;  // the islands it solved in place in the step
  /// `after` is a solved_state() taken in the middle of the step, after its
  /// islands were solved and before integrate() (a step a rollback
  /// interrupted): replayed islands take their state in it in place of
  /// solving, and integrate() moves them on.
  bool mid_step = false;
  /// Solve the replayed islands anyway and throw std::logic_error if their
  /// result is not `after`'s bit for bit (a check for tests).
  bool verify = false;
};

}  // namespace soda
