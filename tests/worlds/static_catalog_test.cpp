// StaticCatalog (worlds/src/static_catalog.h): the state the catalog gives a
// fixed static is, bit for bit, the state of the same body inserted into a
// Bullet world the way a territory world inserts it (the state hash,
// snapshots and checkpoints read the catalog, whether or not a world holds
// the body); its box contains the body's Bullet AABB, so a world that loads
// the cells a halo overlaps holds every static the halo can meet.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "body_factory.h"
#include "canonical_dynamics_world.h"
#include "soda/scene/registry.h"
#include "soda/worlds/bullet_bodies.h"
#include "static_catalog.h"

namespace soda {
namespace {

std::vector<Body> statics_of_every_kind() {
  std::vector<Body> out;
  for (const char* name : {"cube-pile", "terrain", "city", "compounds", "pendulums"}) {
    const Scene s = make_scene(name, {20, 1});
    for (const Body& b : s.bodies)
      if (b.is_static && !b.kinematic) {
        out.push_back(b);
        out.back().id = static_cast<BodyId>(out.size());
      }
  }
  Body tilted;  // a turned box away from the origin
  tilted.id = static_cast<BodyId>(out.size() + 1);
  tilted.is_static = true;
  tilted.shape = Shape::box(Vec3(3.0, 0.5, 1.0));
  tilted.position = Vec3(40.0, -2.0, -17.5);
  tilted.orientation = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  out.push_back(tilted);
  return out;
}

TEST(StaticCatalog, StatesAreThoseOfTheBodyInABulletWorldAndBoxesHoldItsAabb) {
  const std::vector<Body> statics = statics_of_every_kind();
  ASSERT_GE(statics.size(), 6u);
  const StaticCatalog catalog(statics);
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  const UniformGrid grid(Vec3::Zero(), 1.0);
  const CellBox everywhere{{-1000, -1000, -1000}, {1000, 1000, 1000}};
  for (const Body& b : statics) {
    const std::size_t i = catalog.find(b.id);
    ASSERT_LT(i, catalog.size());
    std::shared_ptr<btCollisionShape> shape = make_collision_shape(b.shape);
    std::unique_ptr<btRigidBody> body = make_rigid_body(b, *shape);
    add_body_with_canonical_proxy(world, broadphase, body.get(), 1, -1);
    const BodyDynamicState held = read_dynamic_state(*body);
    EXPECT_EQ(std::memcmp(&held, &catalog.state(i), sizeof(BodyDynamicState)), 0) << "body " << b.id;
    btVector3 lo, hi;
    world.updateSingleAabb(body.get());
    lo = body->getBroadphaseHandle()->m_aabbMin;
    hi = body->getBroadphaseHandle()->m_aabbMax;
    const CellBox bullet = grid.cells_overlapping(to_vec3(lo), to_vec3(hi));
    const CellBox box = catalog.cells(i, grid, everywhere);
    EXPECT_TRUE(box.contains(bullet.lo) && box.contains(bullet.hi)) << "body " << b.id << " (" << shape_kind_name(b.shape.kind)
                                                                    << ")";
    world.removeRigidBody(body.get());
  }
  EXPECT_EQ(catalog.find(static_cast<BodyId>(statics.size() + 5)), catalog.size());
}

}  // namespace
}  // namespace soda
