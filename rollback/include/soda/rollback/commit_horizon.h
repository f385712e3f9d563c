// The commit horizon (GVT, DESIGN.md §4): the oldest internal step
// any world may still have to return to. Each world reports its low-water
// mark — without speculation its last completed step boundary (messages it
// has sent are for steps at or after it, and inputs are applied at
// boundaries); with speculation the minimum of its clock and the steps of
// the neighbours' messages it used that may still change (bets not yet
// confirmed, messages of a neighbour that rolled back not yet re-sent) — and
// a world that sends a rollback notice pins the notice's step until the
// receiver has taken it in (a message in flight). GVT is the minimum over
// all marks and pins, read without stopping anyone. Behind
// an interface so that a distributed algorithm (Mattern's two-colour cut)
// can replace the shared-memory one for a transport across machines.
#pragma once

#include <algorithm>
#include <climits>
#include <cstdint>
#include <functional>
#include <mutex>
#include <set>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda {

class CommitHorizon {
 public:
  virtual ~CommitHorizon() = default;
  /// World `world`'s low-water mark is now `step` (internal steps). It is
  /// lowered below gvt() only to the kept checkpoint at or before a step
  /// gvt() is held at (by a pin, or by the world's own mark), and reported
  /// before that hold is released (worlds
  /// trim their states to the checkpoint at or before the gvt() they read;
  /// docs/rollback.md, "Commit horizon with speculation").
  virtual void report(WorldId world, std::int64_t step) = 0;
  /// The minimum over all worlds' low-water marks and the pins: no world
  /// will ever need to restore a step below it.
  virtual std::int64_t gvt() const = 0;
  /// Holds gvt() at or below `step` until unpin(step) (a rollback to `step`
  /// is being prepared); false, and no pin, if gvt() is already above it.
  virtual bool try_pin(std::int64_t step) = 0;
  /// As try_pin, but also false (and no pin) if `step` is below
  /// highest_gvt(): gvt() may go down (a mark lowered under a hold), while
  /// what a world read stays final for it (its commit step), so a change
  /// from outside (a user input at a past step) must not reach below it.
  virtual bool try_pin_final(std::int64_t step) = 0;
  /// The highest value gvt() has computed so far (never goes down): no
  /// step below it may change any more. Any thread.
  virtual std::int64_t highest_gvt() const = 0;
  virtual void unpin(std::int64_t step) = 0;
  /// Holds gvt() at or below `step` until unpin(step), whatever gvt() is
  /// now: over ranks, a notice or rollback arriving from another rank
  /// (its pin moved with it; this rank's gvt() may not yet reflect the
  /// sender's lowered mark, which the ranks' next cut will).
  virtual void pin(std::int64_t step) = 0;
  /// Calls the wake hook for `world` once gvt() >= `step`; false (and no
  /// call) if it already is.
  virtual bool wake_at(WorldId world, std::int64_t step) = 0;
  /// Called (outside any lock of the horizon) with each world whose wake_at
  /// step gvt() reached; set before any world runs.
  virtual void set_wake_hook(std::function<void(WorldId)> hook) = 0;
  /// A reader's hold (a Simulation's SceneReader with past inputs): as pin
  /// and unpin, but gvt_without_readers() leaves it out. Any thread.
  virtual void pin_reader(std::int64_t step) = 0;
  virtual void unpin_reader(std::int64_t step) = 0;
  /// gvt() without the readers' holds: the step below which no world's own
  /// speculation can change anything any more (what the worlds report as
  /// committed; an input at a step a reader holds can still change later
  /// steps, as an input at a past step always can). Any thread.
  virtual std::int64_t gvt_without_readers() const = 0;
  /// Called (outside any lock of the horizon, on the thread that moved it)
  /// each time gvt() or gvt_without_readers() rises above every value it had
  /// before: a report, an unpin, a global value. Readers that wait for a
  /// step to become final, and the committed frontier, follow it. Set before
  /// any world runs; none by default.
  virtual void set_advance_hook(std::function<void()> hook) = 0;
};

/// One machine: the marks under one mutex (each world reports once a step).
/// Over ranks (docs/mpi.md) it holds one rank's worlds and pins, and
/// gvt() is also bounded by the last value the ranks computed together
/// (set_global; Mattern's cut, mpi/src/gvt_rounds.h).
class SharedMemoryHorizon final : public CommitHorizon {
 public:
  SharedMemoryHorizon(int worlds, std::int64_t start)
      : marks_(static_cast<std::size_t>(worlds), start), wake_(static_cast<std::size_t>(worlds), kNever) {}
  /// One rank's share: only the worlds with `local[w]` report marks here;
  /// gvt() is at most `start` until set_global() says otherwise.
  SharedMemoryHorizon(const std::vector<bool>& local, std::int64_t start)
      : SharedMemoryHorizon(static_cast<int>(local.size()), start) {
    for (std::size_t w = 0; w < local.size(); ++w)
      if (!local[w]) marks_[w] = kNever;
    global_ = start;
  }
  /// The commit horizon the ranks computed together (any value a round
  /// gives, lower ones too: marks may go down under a pin, as on one
  /// machine); wakes the worlds it lets through. Any thread.
  void set_global(std::int64_t step) {
    std::vector<WorldId> woken;
    {
      std::lock_guard lock(mutex_);
      global_ = step;
      woken = due_locked();
    }
    notify(woken);
  }
  /// This rank's part of a cut: the minimum of its worlds' marks and its
  /// pins (not bounded by set_global's value). Any thread.
  std::int64_t local_minimum() const {
    std::lock_guard lock(mutex_);
    std::int64_t low = *std::min_element(marks_.begin(), marks_.end());
    if (!pins_.empty()) low = std::min(low, *pins_.begin());
    return low;
  }
  void report(WorldId world, std::int64_t step) override {
    std::vector<WorldId> woken;
    {
      std::lock_guard lock(mutex_);
      marks_[static_cast<std::size_t>(world)] = step;
      woken = due_locked();
    }
    notify(woken);
  }
  std::int64_t gvt() const override {
    std::lock_guard lock(mutex_);
    return gvt_locked();
  }
  bool try_pin(std::int64_t step) override {
    std::lock_guard lock(mutex_);
    if (step < gvt_locked()) return false;
    pins_.insert(step);
    return true;
  }
  bool try_pin_final(std::int64_t step) override {
    std::lock_guard lock(mutex_);
    if (step < std::max(highest_, gvt_locked())) return false;
    pins_.insert(step);
    return true;
  }
  std::int64_t highest_gvt() const override {
    std::lock_guard lock(mutex_);
    return std::max(highest_, gvt_locked());
  }
  void pin(std::int64_t step) override {
    std::lock_guard lock(mutex_);
    pins_.insert(step);
  }
  void pin_reader(std::int64_t step) override {
    std::lock_guard lock(mutex_);
    reader_pins_.insert(step);
  }
  void unpin_reader(std::int64_t step) override {
    std::vector<WorldId> woken;
    {
      std::lock_guard lock(mutex_);
      auto it = reader_pins_.find(step);
      if (it != reader_pins_.end()) reader_pins_.erase(it);
      woken = due_locked();
    }
    notify(woken);
  }
  std::int64_t gvt_without_readers() const override {
    std::lock_guard lock(mutex_);
    return gvt_without_readers_locked();
  }
  void unpin(std::int64_t step) override {
    std::vector<WorldId> woken;
    {
      std::lock_guard lock(mutex_);
      auto it = pins_.find(step);
      if (it != pins_.end()) pins_.erase(it);
      woken = due_locked();
    }
    notify(woken);
  }
  bool wake_at(WorldId world, std::int64_t step) override {
    std::lock_guard lock(mutex_);
    if (gvt_locked() >= step) return false;
    wake_[static_cast<std::size_t>(world)] = step;
    return true;
  }
  void set_wake_hook(std::function<void(WorldId)> hook) override { hook_ = std::move(hook); }
  void set_advance_hook(std::function<void()> hook) override { advance_hook_ = std::move(hook); }

 private:
  // Outside the lock: the worlds whose wake_at step gvt() reached, then the
  // advance hook if gvt() rose above every earlier value.
  void notify(const std::vector<WorldId>& woken) {
    for (WorldId w : woken) hook_(w);
    if (!advance_hook_) return;
    bool rose = false;
    {
      std::lock_guard lock(mutex_);
      const std::int64_t g = gvt_locked(), w = gvt_without_readers_locked();
      rose = g > notified_ || w > notified_without_readers_;
      notified_ = std::max(notified_, g);
      notified_without_readers_ = std::max(notified_without_readers_, w);
    }
    if (rose) advance_hook_();
  }
  static constexpr std::int64_t kNever = INT64_MAX;
  std::vector<WorldId> due_locked() {
    std::vector<WorldId> out;
    const std::int64_t g = gvt_locked();
    for (std::size_t w = 0; w < wake_.size(); ++w)
      if (wake_[w] <= g) {
        wake_[w] = kNever;
        out.push_back(static_cast<WorldId>(w));
      }
    return out;
  }
  std::int64_t gvt_without_readers_locked() const {
    std::int64_t low = std::min(global_, *std::min_element(marks_.begin(), marks_.end()));
    if (!pins_.empty()) low = std::min(low, *pins_.begin());
    return low;
  }
  std::int64_t gvt_locked() const {
    std::int64_t low = gvt_without_readers_locked();
    if (!reader_pins_.empty()) low = std::min(low, *reader_pins_.begin());
    highest_ = std::max(highest_, low);
    return low;
  }
  mutable std::mutex mutex_;
  std::vector<std::int64_t> marks_;
  std::multiset<std::int64_t> pins_;
  std::multiset<std::int64_t> reader_pins_;  // pin_reader: readers' holds
  mutable std::int64_t highest_ = INT64_MIN;  // highest gvt_locked() result (highest_gvt())
  std::int64_t global_ = kNever;    // over ranks: the ranks' last GVT (set_global); one machine: no bound
  std::vector<std::int64_t> wake_;  // per world: the gvt it waits for
  std::function<void(WorldId)> hook_ = [](WorldId) {};
  std::function<void()> advance_hook_;  // none: no reader waits for gvt()
  std::int64_t notified_ = INT64_MIN;   // the highest gvt() advance_hook_ was called for
  std::int64_t notified_without_readers_ = INT64_MIN;  // and gvt_without_readers()
};

}  // namespace soda
