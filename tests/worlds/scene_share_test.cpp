// scene_share (worlds/scene_share.h): a territory world built from a share
// of the scene that keeps it holds exactly what it holds when built from the
// whole scene (owned bodies, joints, kinematic bodies); a world the share
// drops holds no dynamic body; every dynamic body is in exactly one world's
// share. Scenes with joint groups across cells (their anchor decides),
// kinematic bodies and level geometry. A share cuts a static mesh or
// heightfield to the part its worlds may meet, which those worlds' tests
// visit exactly as the whole's.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <btBulletCollisionCommon.h>

#include "concave_shapes.h"
#include "soda/grid/partition.h"
#include "soda/worlds/scene_share.h"
#include "soda/worlds/territory_world.h"
#include "world_test_util.h"
#include "worlds/heightfield_mesh.h"

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

// Every triangle a query visits, as the query's callback sees it.
struct Visits final : btTriangleCallback {
  struct Visit {
    int part, index;
    btScalar corners[9];
  };
  std::vector<Visit> seen;
  void processTriangle(btVector3* t, int part, int index) override {
    Visit v{part, index, {}};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) v.corners[3 * k + a] = t[k][a];
    seen.push_back(v);
  }
};

bool same_visits(const Visits& a, const Visits& b) {
  if (a.seen.size() != b.seen.size()) return false;
  for (std::size_t i = 0; i < a.seen.size(); ++i)
    if (a.seen[i].part != b.seen[i].part || a.seen[i].index != b.seen[i].index ||
        std::memcmp(a.seen[i].corners, b.seen[i].corners, sizeof a.seen[i].corners) != 0)
      return false;
  return true;
}

std::size_t triangles_of(const Shape& s) {
  if (s.kind == ShapeKind::TriangleMesh) return s.mesh->triangles.size();
  const HeightfieldData& h = *s.heightfield;
  const bool window = h.window.columns != 0;
  return 2 * static_cast<std::size_t>((window ? h.window.columns : h.columns) - 1) *
         static_cast<std::size_t>((window ? h.window.rows : h.rows) - 1);
}

Scene valley_as_mesh(Scene s) {
  for (Body& b : s.bodies)
    if (b.shape.kind == ShapeKind::Heightfield) b.shape = Shape::triangle_mesh(test::mesh_of(*b.shape.heightfield));
  return s;
}

// For the terrain valley as a heightfield and as a mesh, 4 territories, each
// world's share: the level geometry is cut (fewer triangles than the whole),
// keeps the whole's extents, radius and Bullet AABB, and a box anywhere
// within the map's reach of a cell of the world (as far as a halo of its
// bodies goes) visits the same triangles, in the same order, with the same
// part, index and corner bits, as the whole. The whole mesh visits in
// ascending triangle order.
TEST(SceneShare, LevelGeometryIsCutToWhatTheWorldsMayMeet) {
  const Scene heightfield = test::scene("terrain", 60);
  for (const Scene& whole : {heightfield, valley_as_mesh(heightfield)}) {
    const TerritoryMap map = make_partition("kmeans", whole, 4, GridOptions{});
    const Body& ground = whole.bodies.front();
    ASSERT_TRUE(ground.shape.kind == ShapeKind::TriangleMesh || ground.shape.kind == ShapeKind::Heightfield);
    const std::string what = shape_kind_name(ground.shape.kind);
    const std::shared_ptr<btCollisionShape> whole_shape = shared_concave_shape(ground.shape);
    btTransform at;
    at.setIdentity();
    btVector3 whole_lo, whole_hi;
    whole_shape->getAabb(at, whole_lo, whole_hi);
    std::size_t part_triangles = 0;
    for (WorldId w = 0; w < map.world_count(); ++w) {
      const Scene share = scene_share(whole, map, [w](WorldId v) { return v == w; });
      const Shape& part = share.bodies.front().shape;
      ASSERT_EQ(share.bodies.front().id, ground.id);
      EXPECT_LT(triangles_of(part), triangles_of(ground.shape)) << what << ", world " << w;
      part_triangles += triangles_of(part);
      EXPECT_EQ(part.local_half_extents(), ground.shape.local_half_extents()) << what;
      EXPECT_EQ(part.bounding_radius(), ground.shape.bounding_radius()) << what;
      const std::shared_ptr<btCollisionShape> part_shape = shared_concave_shape(part);
      btVector3 lo, hi;
      part_shape->getAabb(at, lo, hi);
      EXPECT_TRUE(lo == whole_lo && hi == whole_hi) << what << ", world " << w;
      std::size_t queries = 0, visited = 0;
      for (const CellCoord& own : map.cells_of(w)) {
        const CellBox reach = CellBox{own, own}.grown(map.reach());
        const Vec3 lo_at = map.grid().cell_min(reach.lo) - ground.position;  // the ground is not turned
        const Vec3 hi_at = map.grid().cell_max(reach.hi) - ground.position;
        const btVector3 query_lo(btScalar(lo_at.x()), btScalar(lo_at.y()), btScalar(lo_at.z()));
        const btVector3 query_hi(btScalar(hi_at.x()), btScalar(hi_at.y()), btScalar(hi_at.z()));
        Visits from_whole, from_part;
        static_cast<const btConcaveShape*>(whole_shape.get())->processAllTriangles(&from_whole, query_lo, query_hi);
        static_cast<const btConcaveShape*>(part_shape.get())->processAllTriangles(&from_part, query_lo, query_hi);
        EXPECT_TRUE(same_visits(from_whole, from_part)) << what << ", world " << w << ", cell " << own.x << " "
                                                        << own.y << " " << own.z << ": " << from_whole.seen.size()
                                                        << " triangles from the whole, " << from_part.seen.size()
                                                        << " from the part";
        for (std::size_t i = 1; i < from_whole.seen.size(); ++i)
          if (ground.shape.kind == ShapeKind::TriangleMesh) {
            const auto id = [](const Visits::Visit& v) { return (std::int64_t{v.part} << 20) + v.index; };
            EXPECT_LT(id(from_whole.seen[i - 1]), id(from_whole.seen[i])) << what;
          }
        ++queries, visited += from_whole.seen.size();
      }
      EXPECT_GT(visited, queries) << what << ", world " << w;  // the queries meet the ground
      if (part.kind == ShapeKind::Heightfield) {  // a sample it does not hold is an error, never a miss
        Visits everything;
        EXPECT_THROW(static_cast<const btConcaveShape*>(part_shape.get())->processAllTriangles(&everything, lo, hi),
                     std::logic_error);
      }
    }
    std::printf("[ terrain 60 as a %s, K 4 ] the whole holds %zu triangles, the four worlds' parts %zu\n",
                what.c_str(), triangles_of(ground.shape), part_triangles);
  }
}

}  // namespace
}  // namespace soda
