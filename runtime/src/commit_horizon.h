// Internal: the commit horizon (GVT, DESIGN.md §4): the oldest step any
// world may still have to return to. Each world reports its low-water mark —
// without speculation its last completed step boundary (messages it has sent
// are for steps at or after it, and inputs are applied at boundaries) — and
// GVT is the minimum over all worlds, read without stopping anyone. Behind
// an interface so that a distributed algorithm (Mattern's two-colour cut)
// can replace the shared-memory one for a transport across machines.
#pragma once

#include <algorithm>
#include <cstdint>
#include <mutex>
#include <set>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda {

class CommitHorizon {
 public:
  virtual ~CommitHorizon() = default;
  /// World `world`'s low-water mark is now `step` (scene steps). Only a
  /// rollback lowers it, and never below gvt().
  virtual void report(WorldId world, std::int64_t step) = 0;
  /// The minimum over all worlds' low-water marks and the pins: no world
  /// will ever need to restore a step below it.
  virtual std::int64_t gvt() const = 0;
  /// Holds gvt() at or below `step` until unpin(step) (a rollback to `step`
  /// is being prepared); false, and no pin, if gvt() is already above it.
  virtual bool try_pin(std::int64_t step) = 0;
  virtual void unpin(std::int64_t step) = 0;
};

/// One machine: the marks under one mutex (each world reports once a step).
class SharedMemoryHorizon final : public CommitHorizon {
 public:
  SharedMemoryHorizon(int worlds, std::int64_t start) : marks_(static_cast<std::size_t>(worlds), start) {}
  void report(WorldId world, std::int64_t step) override {
    std::lock_guard lock(mutex_);
    marks_[static_cast<std::size_t>(world)] = step;
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
  void unpin(std::int64_t step) override {
    std::lock_guard lock(mutex_);
    auto it = pins_.find(step);
    if (it != pins_.end()) pins_.erase(it);
  }

 private:
  std::int64_t gvt_locked() const {
    std::int64_t low = *std::min_element(marks_.begin(), marks_.end());
    if (!pins_.empty()) low = std::min(low, *pins_.begin());
    return low;
  }
  mutable std::mutex mutex_;
  std::vector<std::int64_t> marks_;
  std::multiset<std::int64_t> pins_;
};

}  // namespace soda
