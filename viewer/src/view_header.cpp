#include "soda/viewer/view_header.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace soda::viewer {

replay::ViewHeader make_view_header(const Scene& scene, const TerritoryMap& map) {
  replay::ViewHeader h;
  h.scene = scene.name;
  h.seed = scene.seed;
  h.dt = scene.settings.dt;
  h.territories = map.world_count();
  h.grid = map.grid();
  h.box = map.box();
  h.bodies.reserve(scene.bodies.size());
  for (const Body& b : scene.bodies) h.bodies.push_back({b.id, b.is_static, b.shape, b.position, b.orientation});
  std::sort(h.bodies.begin(), h.bodies.end(),
            [](const replay::ViewBody& a, const replay::ViewBody& b) { return a.id < b.id; });
  return h;
}

std::vector<std::uint16_t> cell_owners(const TerritoryMap& map) {
  if (map.world_count() > std::numeric_limits<std::uint16_t>::max())
    throw std::invalid_argument("the viewer shows at most 65535 worlds, got " + std::to_string(map.world_count()));
  const auto owners = map.owners();
  return {owners.begin(), owners.end()};
}

}  // namespace soda::viewer
