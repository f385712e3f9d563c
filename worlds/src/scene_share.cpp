// scene_share: the bodies and joints a process's territory worlds hold at
// their start (scene_share.h).
#include "soda/worlds/scene_share.h"

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "body_factory.h"
#include "concave_cut.h"
#include "soda/worlds/bullet_bodies.h"
#include "territory_world_parts.h"

namespace soda {

namespace {

bool is_level_geometry(const Body& b) {
  return b.is_static && !b.kinematic &&
         (b.shape.kind == ShapeKind::TriangleMesh || b.shape.kind == ShapeKind::Heightfield);
}

// The cells within `grow` cells of a kept world's cell, a bit per cell of
// the map's box (CellBox::index); boxes are tested by the cells they
// overlap, clamped to the box as the worlds clamp a halo (concave_cut.h).
class KeptCells {
 public:
  KeptCells(const TerritoryMap& map, const std::function<bool(WorldId)>& keep, int grow)
      : map_(map), bits_(static_cast<std::size_t>((map.box().count() + 63) / 64), 0) {
    const CellBox& box = map.box();
    for (WorldId w = 0; w < map.world_count(); ++w) {
      if (!keep(w)) continue;
      for (const CellCoord& own : map.cells_of(w)) {
        const CellBox c = clamp(CellBox{own, own}.grown(grow));
        for (int x = c.lo.x; x <= c.hi.x; ++x)
          for (int y = c.lo.y; y <= c.hi.y; ++y)
            for (int z = c.lo.z; z <= c.hi.z; ++z) {
              const std::size_t i = box.index(CellCoord{x, y, z});
              bits_[i / 64] |= std::uint64_t{1} << (i % 64);
            }
      }
    }
  }

  bool any(const Vec3& lo, const Vec3& hi) const {
    const CellBox c = clamp(map_.grid().cells_overlapping(lo, hi));
    for (int x = c.lo.x; x <= c.hi.x; ++x)
      for (int y = c.lo.y; y <= c.hi.y; ++y)
        for (int z = c.lo.z; z <= c.hi.z; ++z) {
          const std::size_t i = map_.box().index(CellCoord{x, y, z});
          if ((bits_[i / 64] >> (i % 64)) & 1) return true;
        }
    return false;
  }

 private:
  CellBox clamp(const CellBox& c) const { return {map_.box().clamp(c.lo), map_.box().clamp(c.hi)}; }

  const TerritoryMap& map_;
  std::vector<std::uint64_t> bits_;
};

}  // namespace

Scene scene_share(const Scene& scene, const TerritoryMap& map, const std::function<bool(WorldId)>& keep,
                  bool cut_level_geometry) {
  std::unordered_set<BodyId> statics;
  std::unordered_map<BodyId, const Body*> dynamic;
  for (const Body& b : scene.bodies) {
    if (b.is_static)
      statics.insert(b.id);
    else
      dynamic.emplace(b.id, &b);
  }
  std::vector<const Joint*> joints;
  joints.reserve(scene.joints.size());
  for (const Joint& j : scene.joints) joints.push_back(&j);
  const std::unordered_map<BodyId, BodyId> anchors =
      joint_anchors(joints, [&](BodyId b) { return statics.count(b) > 0; });
  // The home rule of TerritoryWorld's constructor (insert_owned_and_joints).
  auto kept = [&](const Body& b) {
    auto a = anchors.find(b.id);
    auto home = a == anchors.end() ? dynamic.end() : dynamic.find(a->second);
    const Body& at = home == dynamic.end() ? b : *home->second;
    return keep(map.owner_of(to_vec3(to_bt(at.position))));
  };
  Scene share;
  share.name = scene.name;
  share.seed = scene.seed;
  share.settings = scene.settings;
  // Level geometry is cut to what the kept worlds may meet, the cells
  // marked once for the first body that needs them.
  std::unique_ptr<KeptCells> near[2];  // a body not turned, turned
  const NearKeptWorlds is_near = [&](const Vec3& lo, const Vec3& hi, bool turned) {
    std::unique_ptr<KeptCells>& cells = near[turned ? 1 : 0];
    if (!cells) cells = std::make_unique<KeptCells>(map, keep, (turned ? 2 : 1) * (map.reach() + 1));
    return cells->any(lo, hi);
  };
  std::unordered_set<BodyId> dropped;
  for (const Body& b : scene.bodies) {
    if (b.is_static || kept(b)) {
      share.bodies.push_back(b);
      if (cut_level_geometry && is_level_geometry(b)) share.bodies.back().shape = cut_concave_shape(b, is_near);
    } else {
      dropped.insert(b.id);
    }
  }
  // A joint with an end that is not in the scene stays: the world refuses it
  // with its own error, as when built from the whole scene.
  for (const Joint& j : scene.joints)
    if (!dropped.count(j.body_a) && !dropped.count(j.body_b)) share.joints.push_back(j);
  return share;
}

}  // namespace soda
