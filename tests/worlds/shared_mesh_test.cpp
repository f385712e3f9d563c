// A static triangle mesh's geometry is held once per process, not once per
// world (worlds/src/concave_shapes.h): the worlds of one process share one
// Bullet shape (its btScalar vertices and BVH), and a world's own cost for
// the mesh is one rigid body and proxy. Measured with the heap's counters:
// eight territory worlds of a scene with a large mesh against the same
// scene with a box in its place. SODA_MESH_TRIANGLES sets the mesh's size
// (default 200,000 triangles; docs/memory.md quotes a 1,000,000-triangle run).
#include <malloc.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "concave_shapes.h"
#include "soda/scene/registry.h"
#include "worlds/heightfield_mesh.h"
#include "soda/grid/partition.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/scene_share.h"
#include "soda/worlds/territory_world.h"

namespace soda {
namespace {

// Bytes in use: small chunks and mmapped ones (a large vector's).
std::size_t heap_bytes() {
  const struct mallinfo2 m = mallinfo2();
  return m.uordblks + m.hblkhd;
}

// A side x side grid of 1 m quads (2 side^2 triangles), gently waved, under
// 16 cubes.
Scene mesh_scene(int side, bool with_mesh) {
  Scene s;
  s.name = "mesh";
  Body ground;
  ground.id = 0;
  ground.is_static = true;
  if (with_mesh) {
    auto mesh = std::make_shared<TriangleMeshData>();
    for (int j = 0; j <= side; ++j)
      for (int i = 0; i <= side; ++i)
        mesh->vertices.emplace_back(i - 0.5 * side, 0.2 * std::sin(0.3 * i) * std::cos(0.2 * j), j - 0.5 * side);
    for (int j = 0; j < side; ++j)
      for (int i = 0; i < side; ++i) {
        const auto a = static_cast<std::uint32_t>(j * (side + 1) + i), b = a + 1,
                   c = a + static_cast<std::uint32_t>(side + 1), d = c + 1;
        mesh->triangles.push_back({a, c, b});
        mesh->triangles.push_back({b, c, d});
      }
    ground.shape = Shape::triangle_mesh(std::move(mesh));
  } else {
    ground.shape = Shape::box(Vec3(0.5 * side, 0.5, 0.5 * side));
  }
  s.bodies.push_back(std::move(ground));
  for (int k = 0; k < 16; ++k) {
    Body b;
    b.id = static_cast<BodyId>(k + 1);
    b.shape = Shape::box(Vec3(0.5, 0.5, 0.5));
    b.position = Vec3(-0.25 * side + 0.5 * side * (k % 4) / 3.0, 2.0, -0.25 * side + 0.5 * side * (k / 4) / 3.0);
    s.bodies.push_back(std::move(b));
  }
  return s;
}

struct Growth {
  std::size_t first = 0;  // heap bytes the first world took
  std::size_t rest = 0;   // the next seven together
};

// Each world built and predicted once: a world holds the statics near its
// cells from its first predict on (docs/partitioned-step.md, §2a).
Growth build_worlds(const Scene& s, const TerritoryMap& map) {
  std::vector<std::unique_ptr<TerritoryWorld>> worlds;
  Growth g;
  const std::size_t h0 = heap_bytes();
  worlds.push_back(std::make_unique<TerritoryWorld>(s, 0, map));
  worlds.back()->predict();
  const std::size_t h1 = heap_bytes();
  for (WorldId w = 1; w < map.world_count(); ++w) {
    worlds.push_back(std::make_unique<TerritoryWorld>(s, w, map));
    worlds.back()->predict();
  }
  g.first = h1 - h0;
  g.rest = heap_bytes() - h1;
  return g;
}

TEST(SharedMesh, EightWorldsHoldOneCopyOfTheGeometry) {
  const char* env = std::getenv("SODA_MESH_TRIANGLES");
  const long triangles = env ? std::atol(env) : 200000;
  const int side = static_cast<int>(std::ceil(std::sqrt(triangles / 2.0)));
  const Scene with = mesh_scene(side, true), without = mesh_scene(side, false);
  const TerritoryMap map = make_partition("kmeans", without, 8, GridOptions{});
  ASSERT_EQ(map.world_count(), 8);
  build_worlds(without, map);  // once to warm up what is allocated once per process
  const Growth b = build_worlds(without, map);
  const Growth a = build_worlds(with, map);
  const double shared = double(a.first) - double(b.first);
  const double per_world = (double(a.rest) - double(b.rest)) / 7.0;
  const std::size_t scene_bytes = with.bodies[0].shape.mesh->vertices.size() * sizeof(Vec3) +
                                  with.bodies[0].shape.mesh->triangles.size() * 12;
  std::printf("[ shared mesh %s, %zu triangles, 8 territory worlds ] scene data %zu bytes (once); Bullet shape and "
              "BVH %.0f bytes (the first world, once; concave_shape_bytes %zu); each further world %.0f bytes "
              "for the mesh (its rigid body and proxy)\n",
              kPrecisionName, with.bodies[0].shape.mesh->triangles.size(), scene_bytes, shared,
              concave_shape_bytes(with.bodies[0].shape), per_world);
  // The first world builds the shape: at least the btScalar vertices and
  // int indices; each further world adds far less than a copy would.
  EXPECT_GT(shared, double(with.bodies[0].shape.mesh->triangles.size() * 3 * sizeof(int)));
  EXPECT_LT(per_world, 4096.0);
  // Copies of a shape (a scene's, a snapshot's) map to the one Bullet shape.
  const Shape copy = with.bodies[0].shape;
  EXPECT_EQ(make_collision_shape(copy).get(), make_collision_shape(with.bodies[0].shape).get());
}

// What an MPI rank holds of the mesh (scene_share.h): the part near the
// worlds it steps (world w on rank w % R, MpiGroup's default), its scene
// data and its Bullet shape and BVH, against the whole mesh on one rank.
// 8 k-means territories; SODA_MESH_TRIANGLES sets the mesh's size as above.
// On 2 ranks a rank holds at most 0.6 of the whole, on 4 at most 0.35.
TEST(SharedMesh, ARankHoldsThePartOfTheMeshNearItsWorlds) {
  const char* env = std::getenv("SODA_MESH_TRIANGLES");
  const long triangles = env ? std::atol(env) : 200000;
  const int side = static_cast<int>(std::ceil(std::sqrt(triangles / 2.0)));
  // 64 cubes spread over the whole mesh, for territories that split it.
  Scene with = mesh_scene(side, true);
  with.bodies.resize(1);
  for (int k = 0; k < 64; ++k) {
    Body b;
    b.id = static_cast<BodyId>(k + 1);
    b.shape = Shape::box(Vec3(0.5, 0.5, 0.5));
    b.position = Vec3(side * (-0.45 + 0.9 * (k % 8) / 7.0), 2.0, side * (-0.45 + 0.9 * (k / 8) / 7.0));
    with.bodies.push_back(std::move(b));
  }
  const TerritoryMap map = make_partition("kmeans", with, 8, GridOptions{});
  const auto bytes = [](const Shape& s) {
    const std::size_t data = s.mesh->vertices.size() * sizeof(Vec3) + s.mesh->triangles.size() * 12;
    return data + concave_shape_bytes(s);  // concave_shape_bytes counts a part's whole_index
  };
  const double whole = double(bytes(with.bodies[0].shape));
  for (int ranks : {1, 2, 4}) {
    std::size_t largest = 0, largest_triangles = 0;
    for (int r = 0; r < ranks; ++r) {
      const Scene share = scene_share(with, map, [&](WorldId w) { return w % ranks == r; });
      const Shape& part = share.bodies[0].shape;
      ASSERT_EQ(part.kind, ShapeKind::TriangleMesh);
      if (bytes(part) > largest) largest = bytes(part), largest_triangles = part.mesh->triangles.size();
    }
    std::printf("[ mesh %s, %zu triangles, 8 territories on %d rank(s) ] the largest rank holds %zu triangles, "
                "%zu bytes (scene data, Bullet shape and BVH): %.3f of the whole\n",
                kPrecisionName, with.bodies[0].shape.mesh->triangles.size(), ranks, largest_triangles, largest,
                double(largest) / whole);
    const double most = ranks == 1 ? 1.0 : ranks == 2 ? 0.6 : 0.35;
    EXPECT_LE(double(largest), most * whole) << ranks << " ranks";
  }
}

// The terrain scene on 8 territory worlds: its heightfield, and the same
// valley as a triangle mesh, against a box ground in its place. What each
// world beyond the first pays is its static body, not the triangles.
// SODA_TERRAIN_N sets the scene's bodies (default 200: 6,400 triangles;
// docs/results/terrain-mesh-memory.md quotes 5,000: 640,000).
TEST(SharedMesh, TerrainOnEightWorldsHoldsOneCopy) {
  const char* env = std::getenv("SODA_TERRAIN_N");
  const int n = env ? std::atoi(env) : 200;
  const Scene hf = make_scene("terrain", {n, 1});
  ASSERT_EQ(hf.bodies[0].shape.kind, ShapeKind::Heightfield);
  Scene mesh = hf, box = hf;
  mesh.bodies[0].shape = Shape::triangle_mesh(test::mesh_of(*hf.bodies[0].shape.heightfield));
  box.bodies[0].shape = Shape::box(hf.bodies[0].shape.local_half_extents());
  GridOptions bodies_only;
  bodies_only.triangle_weight = 0;  // one map for the three
  const TerritoryMap map = make_partition("kmeans", box, 8, bodies_only);
  ASSERT_EQ(map.world_count(), 8);
  build_worlds(box, map);  // warm up what is allocated once per process
  const Growth b = build_worlds(box, map);
  for (const Scene* s : {&hf, static_cast<const Scene*>(&mesh)}) {
    const Growth a = build_worlds(*s, map);
    const Shape& shape = s->bodies[0].shape;
    const std::size_t triangles = shape.mesh ? shape.mesh->triangles.size()
                                             : 2 * static_cast<std::size_t>(shape.heightfield->columns - 1) *
                                                   static_cast<std::size_t>(shape.heightfield->rows - 1);
    const double shared = double(a.first) - double(b.first);
    const double per_world = (double(a.rest) - double(b.rest)) / 7.0;
    std::printf("[ terrain %d as a %s, %s, %zu triangles, 8 territory worlds ] the first world %.0f bytes more than "
                "on a box (the shared shape; concave_shape_bytes %zu); each further world %.0f bytes\n",
                n, shape_kind_name(shape.kind), kPrecisionName, triangles, shared, concave_shape_bytes(shape),
                per_world);
    EXPECT_GT(shared, 0.5 * double(concave_shape_bytes(shape)));
    EXPECT_LT(per_world, 4096.0);
  }
}

}  // namespace
}  // namespace soda
