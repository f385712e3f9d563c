// The triangles of level geometry each cell's bodies can touch: the part of
// a cell's cost that static triangle meshes and heightfields make
// (docs/loadbalance.md, "Triangles").
//
// A dynamic body over a mesh or heightfield pays, every step it is awake,
// a narrowphase test for each triangle under its box (Bullet's concave
// collision walks them; a static triangle nobody touches costs nothing). A
// body whose home cell is c and whose extent is at most a cell lies inside
// c grown by half a cell on every side, so the triangles it can touch are
// those whose bounding box overlaps that grown cell: cell_triangles counts
// them per box cell. The partitions weigh each dynamic body by
// 1 + triangle_weight x that count (GridOptions::triangle_weight), the cost
// model charges per_triangle per awake body and triangle (cost_model.h).
//
// Invariants:
//  1. a pure function of the scene's static bodies, the grid and the box
//     (integers from floor() of positions computed in one order, no fused
//     operations): every process and every map of the same grid gets the
//     same counts;
//  2. only triangles overlapping the box's cells (grown) count, each once
//     per cell it reaches; a scene without meshes or heightfields gives all
//     zeros.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/grid/grid.h"

namespace soda {

/// Per box cell (box.index() order): the triangles of the scene's static
/// triangle meshes and heightfields whose bounding box overlaps the cell
/// grown by half a cell on every side. Throws GridError for a non-finite
/// vertex. Pure function; thread-safe.
std::vector<std::int32_t> cell_triangles(const std::vector<Body>& bodies, const UniformGrid& grid,
                                         const CellBox& box);

/// True if any body is a static triangle mesh or heightfield.
bool has_level_geometry(const std::vector<Body>& bodies);

}  // namespace soda
