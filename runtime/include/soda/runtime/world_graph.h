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
/// (worlds/reach.h), speed = run_reach_speed(scene, reach_speed), and far
/// enough for a body of `added_extent` metres across (bounding-sphere
/// diameter) that an input may add. Throws std::invalid_argument for a
/// negative or non-finite reach_speed or added_extent.
TerritoryMap map_with_reach(const Scene& scene, const TerritoryMap& map, double reach_speed,
                            double added_extent = 0);

/// A run's reach speed: `reach_speed` m/s or, if 0, scene_reach_speed(scene).
double run_reach_speed(const Scene& scene, double reach_speed);

/// Why a run on `map` (reach included) at reach speed `speed` cannot take
/// `body` by input: its halo could reach worlds that are not neighbours. ""
/// if it can. The reason names its size and the largest the run takes.
std::string reach_refusal(const Body& body, const SceneSettings& settings, const TerritoryMap& map, double speed);

}  // namespace soda
