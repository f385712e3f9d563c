// Rollbacks of every world at once (speculation, docs/rollback.md).
// A rollback that voids merge messages (Glue with entries, Fragments, Gather,
// Results; is_merge_message in runtime/src/speculation.h) is
// one of the whole merged island's worlds, which re-merge; done world by
// world, worlds could keep using each other's in-between merge messages and
// roll each other back forever. So such a rollback is posted here with a new
// epoch: every world restores the step (if it passed it), and every message
// of that step or later sent before the world saw the epoch is void. Messages
// carry the epoch their sender had seen. The step is pinned in the commit
// horizon until every world has taken the rollback in.
#pragma once

#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

#include "soda/rollback/commit_horizon.h"

namespace soda {

class RollbackBoard {
 public:
  struct Entry {
    std::uint32_t epoch = 0;
    std::int64_t step = 0;    // every world restores its state kept at this step
    std::int64_t pinned = 0;  // pinned once per world until each has taken it in
  };
  /// `wake(w)` must make world w look at the board soon (a Wake message).
  RollbackBoard(int worlds, CommitHorizon& horizon, std::function<void(WorldId)> wake)
      : worlds_(worlds), horizon_(horizon), wake_(std::move(wake)) {}

  /// Every world to roll back to `step` (internal, a checkpoint step at or
  /// below `pinned`, the step that changed); returns the epoch. Throws
  /// std::logic_error if `pinned` is below the commit horizon.
  std::uint32_t post(std::int64_t step, std::int64_t pinned, WorldId by) {
    std::uint32_t epoch = 0;
    {
      std::lock_guard lock(mutex_);
      for (int i = 0; i < worlds_; ++i)
        if (!horizon_.try_pin(pinned)) throw std::logic_error("a rollback of every world below the commit horizon");
      epoch = static_cast<std::uint32_t>(entries_.size()) + 1;
      entries_.push_back(Entry{epoch, step, pinned});
    }
    for (WorldId w = 0; w < worlds_; ++w)
      if (w != by) wake_(w);
    return epoch;
  }
  /// Rollbacks with an epoch above `seen`, oldest first.
  std::vector<Entry> since(std::uint32_t seen) const {
    std::lock_guard lock(mutex_);
    return {entries_.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(seen, entries_.size())),
            entries_.end()};
  }
  /// True if a message of `step` sent at `epoch` was voided by a rollback
  /// the receiver has seen (epoch in (epoch, seen], at or before `step`).
  bool voids(std::uint32_t epoch, std::int64_t step, std::uint32_t seen) const {
    if (epoch >= seen) return false;
    std::lock_guard lock(mutex_);
    for (std::uint32_t e = epoch + 1; e <= seen; ++e)
      if (entries_[e - 1].step <= step) return true;
    return false;
  }

 private:
  int worlds_;
  CommitHorizon& horizon_;
  std::function<void(WorldId)> wake_;
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;  // entries_[e - 1] has epoch e
};

}  // namespace soda
