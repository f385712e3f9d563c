// Internal: the scene's fixed static bodies (kinematic ones excluded) as a
// territory world knows them, and which of them it holds.
//
// A world holds a fixed static in its Bullet world only where one of its
// pairs may need it: from its first step on, the statics that overlap its
// own cells dilated by the map's reach, and any other that the halo of one
// of its owned bodies reaches (find_ghost_targets asks), or that a joint it
// holds ends on (a world that never steps, another rank's, holds only the
// last). The
// rest it knows by description and state only, for readout (the state hash,
// snapshots, checkpoints) and for the root of a merged island, which builds
// a detached copy of a static a fragment's manifold names (statics are
// never written by a solve). Kinematic bodies are not in the catalog: they
// move, and every world holds them.
//
// Why results do not change: a static pair is held by its dynamic body's
// owner (rule H, docs/partitioned-step.md), which holds the static before
// its first collide with it; a static without held pairs has no state in a
// world beyond its broadphase leaf. Cells are those of UniformGrid::
// cells_overlapping, clamped to the map's box on both sides (clamping keeps
// overlapping ranges overlapping), so a bitset over the box says which cells
// are loaded.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "soda/grid/cell.h"
#include "soda/grid/grid.h"
#include "soda/scene/scene.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {

class StaticCatalog {
 public:
  /// Fixed statics only (is_static and not kinematic), any order.
  explicit StaticCatalog(std::vector<Body> statics);

  std::size_t size() const { return bodies_.size(); }
  const Body& body(std::size_t i) const { return bodies_[i]; }
  /// Its raw state in any world: as made and inserted (addRigidBody puts a
  /// static body to ISLAND_SLEEPING); a solve never writes it.
  const BodyDynamicState& state(std::size_t i) const { return states_[i]; }
  /// Index of `id`, or size() if it is not a fixed static.
  std::size_t find(BodyId id) const;
  /// The cells (clamped to `box`) that a box bounding the static's Bullet AABB
  /// overlaps, margins included.
  CellBox cells(std::size_t i, const UniformGrid& grid, const CellBox& box) const;

 private:
  std::vector<Body> bodies_;  // ascending id
  std::vector<BodyDynamicState> states_;
  std::vector<Vec3> lo_, hi_;
};

/// Clamps a cell range to `box` on both sides.
CellBox clamp_cells(const CellBox& cells, const CellBox& box);

}  // namespace soda
