// scene_share: the bodies and joints a process's territory worlds hold at
// their start (scene_share.h).
#include "soda/worlds/scene_share.h"

#include <unordered_map>
#include <unordered_set>

#include "body_factory.h"
#include "soda/worlds/bullet_bodies.h"
#include "territory_world_parts.h"

namespace soda {

Scene scene_share(const Scene& scene, const TerritoryMap& map, const std::function<bool(WorldId)>& keep) {
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
  std::unordered_set<BodyId> dropped;
  for (const Body& b : scene.bodies) {
    if (b.is_static || kept(b))
      share.bodies.push_back(b);
    else
      dropped.insert(b.id);
  }
  // A joint with an end that is not in the scene stays: the world refuses it
  // with its own error, as when built from the whole scene.
  for (const Joint& j : scene.joints)
    if (!dropped.count(j.body_a) && !dropped.count(j.body_b)) share.joints.push_back(j);
  return share;
}

}  // namespace soda
