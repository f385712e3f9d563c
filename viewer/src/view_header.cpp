#include "soda/viewer/view_header.h"

#include <limits>
#include <stdexcept>
#include <string>

namespace soda::viewer {

std::vector<std::uint16_t> cell_owners(const TerritoryMap& map) {
  if (map.world_count() > std::numeric_limits<std::uint16_t>::max())
    throw std::invalid_argument("the viewer shows at most 65535 worlds, got " + std::to_string(map.world_count()));
  const auto owners = map.owners();
  return {owners.begin(), owners.end()};
}

}  // namespace soda::viewer
