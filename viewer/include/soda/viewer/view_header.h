// viewer/ — ViewFrame pieces made from a TerritoryMap (the live source's and
// the tests' in-memory sources'). The header itself: soda::view_header
// (runtime/view_adapter.h).
// Pure functions; safe from any thread.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/replay/view_frame.h"
#include "soda/scene/scene.h"

namespace soda::viewer {

/// The map's owners, one per box cell in box index order (ViewFrame::
/// cell_owner). Throws std::invalid_argument if a world id does not fit 16 bits.
std::vector<std::uint16_t> cell_owners(const TerritoryMap& map);

}  // namespace soda::viewer
