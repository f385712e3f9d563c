// runtime/ — which worlds talk to which: the world adjacency graph of a
// territory map (worlds owning cells within the map's reach of each other
// are neighbours: 26-adjacent cells at reach 1; map_with_reach widens it for
// fast bodies) and a
// next-hop table for relaying a message to a world further away along a
// shortest path. Every world can build it from the map alone.
//
// The partitioned step only ever sends to direct neighbours (ghosts, glue,
// migrants) and relays island fragments along island links, which join
// neighbours; next_hop is what a message for a non-neighbour would follow.
// Immutable after construction; safe to read from many threads.
#pragma once

#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"

namespace soda {

class WorldGraph {
 public:
  explicit WorldGraph(const TerritoryMap& map);

  int world_count() const { return static_cast<int>(neighbours_.size()); }
  /// Direct neighbours, ascending.
  const std::vector<WorldId>& neighbours(WorldId world) const;
  bool adjacent(WorldId a, WorldId b) const;
  /// First world after `from` on a shortest path to `to` (ties: smallest id);
  /// `to` itself for a neighbour, `from` for from == to, kNoWorld if `to` is
  /// unreachable.
  WorldId next_hop(WorldId from, WorldId to) const;
  /// Hops on a shortest path; -1 if unreachable.
  int distance(WorldId from, WorldId to) const;
  /// Largest distance between two worlds (-1 if the graph is not connected).
  int diameter() const;

 private:
  std::vector<std::vector<WorldId>> neighbours_;
  std::vector<std::vector<int>> distance_;      // [from][to]
  std::vector<std::vector<WorldId>> next_hop_;  // [from][to]
};

/// The map a partitioned run uses: `map` with its neighbours reaching
/// max(map.reach(), reach_cells(scene, cell size, speed)) cells
/// (worlds/reach.h), speed = `reach_speed` m/s or, if 0,
/// scene_reach_speed(scene). Throws std::invalid_argument for a negative or
/// non-finite reach_speed.
TerritoryMap map_with_reach(const Scene& scene, const TerritoryMap& map, double reach_speed);

}  // namespace soda
