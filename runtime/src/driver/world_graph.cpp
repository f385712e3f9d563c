#include "soda/runtime/world_graph.h"

#include <cmath>

#include <algorithm>
#include <deque>
#include <sstream>
#include <stdexcept>
#include <string>

#include <BulletCollision/NarrowPhaseCollision/btPersistentManifold.h>  // gContactBreakingThreshold

#include "soda/worlds/reach.h"

namespace soda {

WorldGraph::WorldGraph(const TerritoryMap& map) {
  const int k = map.world_count();
  neighbours_.resize(static_cast<std::size_t>(k));
  for (WorldId w = 0; w < k; ++w) neighbours_[static_cast<std::size_t>(w)] = map.neighbours(w);
  distance_.assign(static_cast<std::size_t>(k), std::vector<int>(static_cast<std::size_t>(k), -1));
  next_hop_.assign(static_cast<std::size_t>(k), std::vector<WorldId>(static_cast<std::size_t>(k), kNoWorld));
  // BFS from every target: next_hop[from][to] = the smallest neighbour of
  // `from` one hop closer to `to`.
  for (WorldId to = 0; to < k; ++to) {
    std::vector<int> d(static_cast<std::size_t>(k), -1);
    std::deque<WorldId> queue{to};
    d[static_cast<std::size_t>(to)] = 0;
    while (!queue.empty()) {
      const WorldId w = queue.front();
      queue.pop_front();
      for (WorldId n : neighbours_[static_cast<std::size_t>(w)])
        if (d[static_cast<std::size_t>(n)] < 0) {
          d[static_cast<std::size_t>(n)] = d[static_cast<std::size_t>(w)] + 1;
          queue.push_back(n);
        }
    }
    for (WorldId from = 0; from < k; ++from) {
      const int df = d[static_cast<std::size_t>(from)];
      distance_[static_cast<std::size_t>(from)][static_cast<std::size_t>(to)] = df;
      if (df < 0) continue;
      if (df == 0) {
        next_hop_[static_cast<std::size_t>(from)][static_cast<std::size_t>(to)] = from;
        continue;
      }
      for (WorldId n : neighbours_[static_cast<std::size_t>(from)])
        if (d[static_cast<std::size_t>(n)] == df - 1) {
          next_hop_[static_cast<std::size_t>(from)][static_cast<std::size_t>(to)] = n;
          break;  // ascending: the smallest
        }
    }
  }
}

const std::vector<WorldId>& WorldGraph::neighbours(WorldId world) const {
  if (world < 0 || world >= world_count()) throw std::out_of_range("WorldGraph: no world " + std::to_string(world));
  return neighbours_[static_cast<std::size_t>(world)];
}

bool WorldGraph::adjacent(WorldId a, WorldId b) const {
  const auto& n = neighbours(a);
  return std::binary_search(n.begin(), n.end(), b);
}

WorldId WorldGraph::next_hop(WorldId from, WorldId to) const {
  neighbours(from), neighbours(to);  // range checks
  return next_hop_[static_cast<std::size_t>(from)][static_cast<std::size_t>(to)];
}

int WorldGraph::distance(WorldId from, WorldId to) const {
  neighbours(from), neighbours(to);
  return distance_[static_cast<std::size_t>(from)][static_cast<std::size_t>(to)];
}

int WorldGraph::diameter() const {
  int d = 0;
  for (const auto& row : distance_)
    for (int x : row) {
      if (x < 0) return -1;
      d = std::max(d, x);
    }
  return d;
}

namespace {

// A scene of one body: what reach_cells needs to size the halo of `body`.
Scene scene_of_one(const Body& body, const SceneSettings& settings) {
  Scene one;
  one.settings = settings;
  one.bodies.push_back(body);
  one.bodies.back().is_static = false;
  return one;
}

// A ball `extent` metres across, standing for the largest body inputs add.
Body ball(double extent) {
  Body b;
  b.shape = Shape::sphere(extent / 2);
  return b;
}

}  // namespace

double run_reach_speed(const Scene& scene, double reach_speed) {
  if (!(reach_speed >= 0) || !std::isfinite(reach_speed))
    throw std::invalid_argument("reach speed must be finite and >= 0 m/s (0: from the scene), got " +
                                std::to_string(reach_speed));
  return reach_speed > 0 ? reach_speed : scene_reach_speed(scene);
}

TerritoryMap map_with_reach(const Scene& scene, const TerritoryMap& map, double reach_speed, double added_extent) {
  if (!(added_extent >= 0) || !std::isfinite(added_extent))
    throw std::invalid_argument("the extent of added bodies must be finite and >= 0 m, got " +
                                std::to_string(added_extent));
  const double speed = run_reach_speed(scene, reach_speed);
  const double cell = map.grid().cell_size();
  int cells = std::max(map.reach(), reach_cells(scene, cell, speed));
  if (added_extent > 0) cells = std::max(cells, reach_cells(scene_of_one(ball(added_extent), scene.settings), cell, speed));
  return map.with_reach(cells);
}

std::string reach_refusal(const Body& body, const SceneSettings& settings, const TerritoryMap& map, double speed) {
  const double cell = map.grid().cell_size();
  if (reach_cells(scene_of_one(body, settings), cell, speed) <= map.reach()) return "";
  // The largest bounding radius r with reach_cells <= reach: r + speed h +
  // gContactBreakingThreshold < reach * cell (worlds/reach.h).
  const double h = settings.dt / std::max(1, settings.substeps);
  const double largest = std::max(0.0, 2.0 * (map.reach() * cell - speed * h - double(gContactBreakingThreshold)));
  std::ostringstream msg;
  msg.precision(3);
  msg << "the body is " << 2.0 * body.shape.bounding_radius() << " m across (bounding-sphere diameter) and this run's "
      << "worlds reach bodies up to about " << largest << " m across (the largest of the scene it started with, "
      << "at a reach speed of " << speed << " m/s); give the run room for it from the start "
      << "(SimulationConfig::runtime.added_extent, soda run sizes it from --inputs) or a higher reach speed";
  return msg.str();
}

}  // namespace soda
