// Internal: the commit horizon (GVT, DESIGN.md §4): the oldest step any
// world may still have to return to. Each world reports its low-water mark —
// without speculation its last completed step boundary (messages it has sent
// are for steps at or after it, and inputs are applied at boundaries) — and
// GVT is the minimum over all worlds, read without stopping anyone. Behind
// an interface so that a distributed algorithm (Mattern's two-colour cut)
// can replace the shared-memory one for a transport across machines.
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "soda/grid/territory_map.h"

namespace soda {

class CommitHorizon {
 public:
  virtual ~CommitHorizon() = default;
  /// World `world`'s low-water mark is now `step` (scene steps; never lower
  /// than what it reported before).
  virtual void report(WorldId world, std::int64_t step) = 0;
  /// The minimum over all worlds' low-water marks: no world will ever need
  /// to restore a step below it.
  virtual std::int64_t gvt() const = 0;
};

/// One machine: every world's mark in an atomic; gvt() reads them all.
class SharedMemoryHorizon final : public CommitHorizon {
 public:
  SharedMemoryHorizon(int worlds, std::int64_t start) : marks_(static_cast<std::size_t>(worlds)) {
    for (auto& m : marks_) m.store(start, std::memory_order_relaxed);
  }
  void report(WorldId world, std::int64_t step) override {
    marks_[static_cast<std::size_t>(world)].store(step, std::memory_order_release);
  }
  std::int64_t gvt() const override {
    std::int64_t low = std::numeric_limits<std::int64_t>::max();
    for (const auto& m : marks_) low = std::min(low, m.load(std::memory_order_acquire));
    return low;
  }

 private:
  std::vector<std::atomic<std::int64_t>> marks_;
};

}  // namespace soda
