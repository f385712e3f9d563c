// scene_share (worlds/scene_share.h): a territory world built from a share
// of the scene that keeps it holds exactly what it holds when built from the
// whole scene (owned bodies, joints, kinematic bodies); a world the share
// drops holds no dynamic body; every dynamic body is in exactly one world's
// share. Scenes with joint groups across cells (their anchor decides),
// kinematic bodies and level geometry.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "soda/grid/partition.h"
#include "soda/worlds/scene_share.h"
#include "soda/worlds/territory_world.h"
#include "world_test_util.h"

namespace soda {
namespace {

TEST(SceneShare, AKeptWorldHoldsWhatTheWholeSceneGivesItAndADroppedOneNoBody) {
  for (const char* name : {"falling-cubes", "ragdolls", "chain-bridge", "conveyor", "terrain"}) {
    const Scene whole = test::scene(name, 60);
    const TerritoryMap map = make_partition("kmeans", whole, 4, GridOptions{});
    std::size_t shared = 0;
    for (WorldId w = 0; w < map.world_count(); ++w) {
      const Scene share = scene_share(whole, map, [w](WorldId v) { return v == w; });
      EXPECT_EQ(share.static_count(), whole.static_count()) << name;
      shared += share.dynamic_count();
      const TerritoryWorld from_whole(whole, w, map);
      const TerritoryWorld from_share(share, w, map);
      EXPECT_EQ(from_share.owned_ids(), from_whole.owned_ids()) << name << ", world " << w;
      EXPECT_EQ(from_share.joint_count(), from_whole.joint_count()) << name << ", world " << w;
      EXPECT_EQ(from_share.bullet_object_count(), from_whole.bullet_object_count()) << name << ", world " << w;
      const WorldId other = (w + 1) % map.world_count();
      EXPECT_EQ(TerritoryWorld(share, other, map).owned_count(), 0u) << name << ", world " << other;
    }
    EXPECT_EQ(shared, whole.dynamic_count()) << name;
  }
}

TEST(SceneShare, KeepingEveryWorldKeepsTheWholeScene) {
  const Scene whole = test::scene("ragdolls", 40);
  const TerritoryMap map = make_partition("kmeans", whole, 3, GridOptions{});
  const Scene share = scene_share(whole, map, [](WorldId) { return true; });
  ASSERT_EQ(share.bodies.size(), whole.bodies.size());
  ASSERT_EQ(share.joints.size(), whole.joints.size());
  for (std::size_t i = 0; i < whole.bodies.size(); ++i) EXPECT_EQ(share.bodies[i].id, whole.bodies[i].id);
  EXPECT_GT(whole.joints.size(), 0u);
  const Scene none = scene_share(whole, map, [](WorldId) { return false; });
  EXPECT_EQ(none.dynamic_count(), 0u);
  EXPECT_TRUE(none.joints.empty());
}

}  // namespace
}  // namespace soda
