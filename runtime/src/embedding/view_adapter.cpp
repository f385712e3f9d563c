#include "soda/runtime/view_adapter.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace soda {

replay::ViewHeader view_header(const Scene& scene, const TerritoryMap& map) {
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
  for (std::size_t i = 1; i < h.bodies.size(); ++i)
    if (h.bodies[i].id == h.bodies[i - 1].id)
      throw std::invalid_argument("view_header: two bodies with id " + std::to_string(h.bodies[i].id));
  return h;
}

std::vector<std::uint16_t> view_cell_owner(const TerritoryMap& map) {
  if (map.world_count() > std::numeric_limits<std::uint16_t>::max())
    throw std::invalid_argument("a viewer shows at most 65535 worlds, got " + std::to_string(map.world_count()));
  const auto owners = map.owners();
  return {owners.begin(), owners.end()};
}

replay::ViewBody view_body(const Body& b) { return {b.id, b.is_static, b.shape, b.position, b.orientation}; }

replay::ViewFrame view_frame(const SceneFrame& frame, const replay::ViewHeader& header, const TerritoryMap* map) {
  replay::ViewFrame v;
  v.step = frame.step;
  const std::size_t n = frame.poses.size();
  const std::string at = "view_frame: step " + std::to_string(frame.step);
  if (frame.owners.size() != n) throw std::invalid_argument(at + ": owners do not match the poses");
  v.position.resize(3 * n);
  v.orientation.resize(4 * n);
  v.sleeping.resize(n);
  v.owner.resize(n);
  // Walks the header's dynamic bodies beside the poses: while they agree the
  // frame holds the header's bodies (no ids, the common case: no inputs).
  auto next_dynamic = [&](std::size_t h) {
    while (h < header.bodies.size() && header.bodies[h].is_static) ++h;
    return h;
  };
  std::size_t h = next_dynamic(0);
  bool header_bodies = true;
  for (std::size_t i = 0; i < n; ++i) {
    const ScenePose& p = frame.poses[i];
    if (i > 0 && p.id <= frame.poses[i - 1].id)
      throw std::invalid_argument(at + ": body " + std::to_string(p.id) + " out of ascending id order");
    if (header_bodies && h < header.bodies.size() && header.bodies[h].id == p.id) h = next_dynamic(h + 1);
    else header_bodies = false;
    for (std::size_t a = 0; a < 3; ++a) v.position[3 * i + a] = static_cast<float>(p.position[a]);
    for (std::size_t a = 0; a < 4; ++a) v.orientation[4 * i + a] = static_cast<float>(p.orientation[a]);
    v.sleeping[i] = p.sleeping ? 1 : 0;
    v.owner[i] = static_cast<std::uint16_t>(frame.owners[i]);
  }
  if (!header_bodies || h != header.bodies.size()) {  // bodies came or went
    std::vector<BodyId>& ids = v.ids.emplace(n);
    for (std::size_t i = 0; i < n; ++i) ids[i] = frame.poses[i].id;
  }
  v.world_busy_ms.reserve(frame.busy_seconds.size());
  for (double s : frame.busy_seconds) v.world_busy_ms.push_back(static_cast<float>(s * 1e3));
  if (map) v.cell_owner = view_cell_owner(*map);
  return v;
}

}  // namespace soda
