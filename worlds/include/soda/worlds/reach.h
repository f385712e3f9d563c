// worlds/ — reach: how many cells a body's halo and its migration can span
// in one step, from a speed bound; the partitioned runtime widens every
// world's neighbourhood to that many cells (TerritoryMap::with_reach), so
// that ghosts, migrants and merged islands only ever go to neighbours
// (docs/partitioned-step.md, "Reach beyond adjacent cells").
//
// A body's halo (bullet_aabb) is its shape's AABB at the step's start united
// with the one at the predicted transform (moved by v·h, v the speed at the
// step's start, h the internal step), grown by gContactBreakingThreshold; its
// migration moves its origin by at most v'·h (v' the speed after the solve,
// the next step's starting speed). Both stay within reach_cells(v) cells
// (Chebyshev distance) of the home cell while every body's speed at every
// step boundary is at most v.
//
// Pure functions of their arguments; thread-safe.
#pragma once

#include "soda/scene/scene.h"

namespace soda {

/// The speed bound a scene is given when the caller sets none (m/s): the
/// fastest initial speed of a dynamic body plus the speed of a free fall
/// through the scene's height along gravity (from the lowest point of any
/// body, statics included, to the highest point of a dynamic one). Not a
/// proof — collisions can pass speed from a heavy body to a light one — but
/// what a scene of throws and falls stays within; a body that outruns it is
/// refused with an error naming it, its speed and the remedy.
double scene_reach_speed(const Scene& scene);

/// Cells (Chebyshev distance from the home cell) that the halo and the
/// migration of any dynamic body of the scene can span in one internal step
/// (dt / substeps) at speeds up to `speed` (m/s), for cells of `cell_size`
/// metres: floor((r + speed·h + gContactBreakingThreshold) / cell_size) + 1,
/// r the largest bounding radius of a dynamic body plus its shape's collision
/// margin, or of a joint group (its members' radii from the group's anchor
/// along the joints: reach.cpp), whichever is larger. At least 1 (adjacent cells, what the runtime always talks to);
/// saturates at kMaxReachCells. Throws std::invalid_argument for a negative
/// or non-finite speed or a cell size <= 0.
int reach_cells(const Scene& scene, double cell_size, double speed);

/// The speed (m/s) that reach_cells() covers with `cells` cells: the
/// largest v with reach_cells(scene, cell_size, v) <= cells (0 if none).
double reach_speed_of(const Scene& scene, double cell_size, int cells);

}  // namespace soda
