// Internal: one world's part of the scene's state at internal step
// boundaries, as kept for going back in time (speculation's checkpoints,
// PartitionedOptions::keep_states). Freed states' storage is reused: GVT
// moves in jumps, and a jump frees many states that the next steps would
// otherwise allocate again (page faults were 3.8 % of a speculative run on
// alternating-load with a state every step); the memory held stays the
// high-water mark. Used by the world's thread only.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <vector>

#include "soda/worlds/territory_world.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {

class KeptStates {
 public:
  using Map = std::map<std::int64_t, WorldSnapshot>;
  /// Keeps `world`'s part at internal step `step` (replacing one kept there).
  void keep(std::int64_t step, const TerritoryWorld& world) {
    WorldSnapshot snapshot;
    if (!spare_.empty()) {
      snapshot = std::move(spare_.back());
      spare_.pop_back();
    }
    world.part_snapshot(snapshot);
    states_.insert_or_assign(step, std::move(snapshot));
    noted();
  }
  /// A state no longer needed: its storage is reused by a later one.
  void recycle(WorldSnapshot&& state) {
    if (spare_.size() < std::max<std::size_t>(4, max_)) spare_.push_back(std::move(state));
  }
  /// Drops (and recycles) the states in [first, last).
  void drop(Map::iterator first, Map::iterator last) {
    while (first != last) {
      recycle(std::move(first->second));
      first = states_.erase(first);
    }
  }
  /// Notes the number kept now in the high-water mark.
  void noted() { max_ = std::max(max_, states_.size()); }
  Map& states() { return states_; }
  const Map& states() const { return states_; }
  /// Most states kept at once.
  std::size_t max() const { return max_; }

 private:
  Map states_;  // by internal step
  std::vector<WorldSnapshot> spare_;
  std::size_t max_ = 0;
};

}  // namespace soda
