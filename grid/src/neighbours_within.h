// Internal: the neighbour lists of a territory map — for every world, the
// other worlds owning a box cell within `reach` cells (Chebyshev distance) of
// one of its box cells (TerritoryMap invariant 3).
#pragma once

#include <vector>

#include "soda/grid/territory_map.h"

namespace soda::detail {

/// One ascending list per world. reach 1: one pass over the box's cells and
/// their 13 forward offsets. reach > 1: per world, its cells dilated by
/// `reach` (three separable 1-D passes) over its bounding box grown by
/// `reach` and clipped to the box, then the owners found there; the cost is
/// the sum of those regions, about the box's cells for compact territories.
std::vector<std::vector<WorldId>> neighbours_within(const CellBox& box, const std::vector<WorldId>& owners,
                                                    int world_count, int reach);

}  // namespace soda::detail
