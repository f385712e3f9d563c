// viewer/ — ViewHeader and ViewFrame pieces made from a Scene and a
// TerritoryMap (the live source's and the tests' in-memory sources').
// Pure functions; safe from any thread.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/replay/view_frame.h"
#include "soda/scene/scene.h"

namespace soda::viewer {

/// The header of `scene` cut by `map`: every body by ascending id, the
/// map's grid and box, its world count.
replay::ViewHeader make_view_header(const Scene& scene, const TerritoryMap& map);

/// The map's owners, one per box cell in box index order (ViewFrame::
/// cell_owner). Throws std::invalid_argument if a world id does not fit 16 bits.
std::vector<std::uint16_t> cell_owners(const TerritoryMap& map);

}  // namespace soda::viewer
