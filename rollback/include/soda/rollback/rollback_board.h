// Rollbacks of every world at once (speculation, docs/rollback.md).
// A rollback that voids merge messages (Glue with entries, Fragments, Gather,
// Results; is_merge_message in runtime/src/speculation/speculation.h) is
// one of the whole merged island's worlds, which re-merge; done world by
// world, worlds could keep using each other's in-between merge messages and
// roll each other back forever. So such a rollback is posted here with a new
// epoch: every world restores the step (if it passed it), and every message
// of that step or later sent before the world saw the epoch is void. Messages
// carry the epoch their sender had seen. The step is pinned in the commit
// horizon until every world has taken the rollback in.
//
// Over ranks (docs/mpi.md, distribute()): every rank holds the same entries
// in the same order. Rank 0 numbers the epochs; a post on another rank goes
// to rank 0 as a message and comes back, like every entry, as a message to
// every rank (append()). The step stays pinned throughout: by the poster
// until its request is on the wire, then by the message in flight (counted
// by the ranks' GVT cut), then once per world of each rank that holds it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
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

  /// Over ranks: how this rank's board reaches rank 0's numbering.
  struct Ranks {
    std::vector<bool> local;  // by world: stepped on this rank (pinned and woken here)
    /// Hands a post to rank 0 (any thread); it comes back through
    /// append(..., ticket, true). Takes over the one pin of `pinned` that
    /// post() holds and releases it once the request is accounted for.
    std::function<void(std::int64_t step, std::int64_t pinned, std::uint64_t ticket)> request;
    /// Throws the error that stops a world (the run is ending: close()).
    std::function<void()> stop;
  };
  /// Spreads this board over ranks (before any world runs).
  void distribute(Ranks ranks) { ranks_ = std::move(ranks); }

  /// Every world to roll back to `step` (internal, a checkpoint step at or
  /// below `pinned`, the step that changed); returns the epoch. Throws
  /// std::logic_error if `pinned` is below the commit horizon. Over ranks
  /// it waits for rank 0's number (ranks_.stop() once closed).
  std::uint32_t post(std::int64_t step, std::int64_t pinned, WorldId by) {
    if (ranks_) return post_over_ranks(step, pinned);
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
  /// Over ranks: the next entry, in rank 0's order (the rank's
  /// communication loop; on rank 0 also a poster). Pins `pinned` once per
  /// world of this rank and wakes them; `mine`: the answer to this rank's
  /// post `ticket`. Returns the entry's epoch.
  std::uint32_t append(std::int64_t step, std::int64_t pinned, std::uint64_t ticket, bool mine) {
    std::uint32_t epoch = 0;
    {
      std::lock_guard lock(mutex_);
      for (bool here : ranks_->local)
        if (here) horizon_.pin(pinned);  // its pin moved with it (CommitHorizon::pin)
      epoch = static_cast<std::uint32_t>(entries_.size()) + 1;
      entries_.push_back(Entry{epoch, step, pinned});
      if (mine) answers_[ticket] = epoch;
    }
    arrived_.notify_all();
    for (WorldId w = 0; w < worlds_; ++w)
      if (ranks_->local[static_cast<std::size_t>(w)]) wake_(w);
    return epoch;
  }
  /// Returns once the board holds `epoch` (a message whose sender had seen
  /// it arrived first; over ranks its entry may still be on its way).
  void await(std::uint32_t epoch) const {
    std::unique_lock lock(mutex_);
    while (entries_.size() < epoch) {
      if (closed_) {
        lock.unlock();
        ranks_->stop();
        return;
      }
      arrived_.wait_for(lock, kPoll);
    }
  }
  /// The run is stopping: waiting posts and awaits call ranks_.stop().
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    arrived_.notify_all();
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
  // How often a waiting post or await looks whether the run is stopping.
  static constexpr std::chrono::milliseconds kPoll{5};

  std::uint32_t post_over_ranks(std::int64_t step, std::int64_t pinned) {
    std::uint64_t ticket = 0;
    {
      std::lock_guard lock(mutex_);
      if (!horizon_.try_pin(pinned)) throw std::logic_error("a rollback of every world below the commit horizon");
      ticket = ++tickets_;
    }
    ranks_->request(step, pinned, ticket);
    std::unique_lock lock(mutex_);
    for (;;) {
      auto it = answers_.find(ticket);
      if (it != answers_.end()) {
        const std::uint32_t epoch = it->second;
        answers_.erase(it);
        return epoch;
      }
      if (closed_) {
        lock.unlock();
        ranks_->stop();
        throw std::logic_error("RollbackBoard: stop() returned");
      }
      arrived_.wait_for(lock, kPoll);
    }
  }

  int worlds_;
  CommitHorizon& horizon_;
  std::function<void(WorldId)> wake_;
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;  // entries_[e - 1] has epoch e
  // Over ranks:
  std::optional<Ranks> ranks_;
  mutable std::condition_variable arrived_;
  std::uint64_t tickets_ = 0;                       // this rank's posts
  std::map<std::uint64_t, std::uint32_t> answers_;  // ticket -> epoch, until its poster takes it
  bool closed_ = false;
};

}  // namespace soda
