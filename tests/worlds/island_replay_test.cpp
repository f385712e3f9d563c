// IslandReplay (worlds/src/island_replay.h) on its own, with plain Bullet
// bodies: which bodies are clean, which islands are replayed (invariant 1),
// manifolds empty at the old run's end are emptied (invariant 2), and
// verify compares without writing (invariant 3).
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "body_factory.h"
#include "island_replay.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/value_codec.h"

namespace soda {
namespace {

Body cube(BodyId id, double x) {
  Body b;
  b.id = id;
  b.shape = Shape::box(Vec3(0.5, 0.5, 0.5));
  b.mass = 1;
  b.position = Vec3(x, 1, 0);
  return b;
}

BodyDynamicState moved(BodyDynamicState s, btScalar dy) {
  s.origin[1] += dy;
  s.linear_velocity[1] = -dy;
  return s;
}

// Four cubes, ids 1..4; the old run's islands {1, 2} and {3} and {4}; its
// states before and after one step; a contact 1-2 in both.
struct Fixture {
  std::vector<std::shared_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  std::vector<btRigidBody*> owned;
  WorldSnapshot before, after;
  LocalIslands islands;
  std::unique_ptr<btPersistentManifold> contact;
  ManifoldState contact_state;

  Fixture() {
    for (BodyId id = 1; id <= 4; ++id) {
      const Body b = cube(id, 2.0 * id);
      shapes.push_back(make_collision_shape(b.shape));
      BodyDynamicState s;
      {
        auto probe = make_rigid_body(b, *shapes.back());
        s = read_dynamic_state(*probe);
      }
      bodies.push_back(make_body_from_state(b, *shapes.back(), s));
      owned.push_back(bodies.back().get());
      before.bodies.push_back(BodySnapshot{b, s});
      after.bodies.push_back(BodySnapshot{b, moved(s, btScalar(0.25))});
    }
    contact = std::make_unique<btPersistentManifold>(owned[0], owned[1], 0, btScalar(0.02), btScalar(0.02));
    btManifoldPoint p(btVector3(0, 0, 0), btVector3(0, 0, 0), btVector3(1, 0, 0), btScalar(-0.01));
    contact->addManifoldPoint(p);
    contact_state = read_manifold_state(*contact);
    before.manifolds.push_back(contact_state);
    ManifoldState later = contact_state;
    later.points[0].applied_impulse = 1.5;
    after.manifolds.push_back(later);
    islands.ids = {1, 2, 3, 4};
    islands.begin = {0, 2, 3, 4};
  }
  /// The bodies' descriptions now: the old run's unless a test changes one.
  std::vector<Body> now;
  std::vector<const Body*> descriptions() {
    if (now.empty())
      for (const BodySnapshot& b : before.bodies) now.push_back(b.description);
    std::vector<const Body*> out;
    for (const Body& b : now) out.push_back(&b);
    return out;
  }
  IslandItems<btPersistentManifold*> held_of_first() {
    IslandItems<btPersistentManifold*> held;
    held.add(0, {1, 2}, contact.get());
    held.finish(1);
    return held;
  }
};

TEST(IslandReplay, RequiresTheOldRun) {
  IslandReplay replay;
  EXPECT_THROW(replay.set(StepReplay{}), std::invalid_argument);
  EXPECT_FALSE(replay.armed());
}

TEST(IslandReplay, ReplaysCleanIslandsTheOldRunSolvedAlike) {
  Fixture f;
  IslandReplay replay;
  replay.set(StepReplay{&f.before, &f.after, &f.islands});
  ASSERT_TRUE(replay.armed());
  replay.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {}, f.before.settings.gravity);
  IslandItems<btPersistentManifold*> held = f.held_of_first();
  btCollisionObject* pair[] = {f.owned[0], f.owned[1]};
  EXPECT_TRUE(replay.take(pair, 2, held, 0));
  IslandItems<btPersistentManifold*> none;
  none.finish(1);
  btCollisionObject* three_four[] = {f.owned[2], f.owned[3]};  // the old run had {3} and {4}
  EXPECT_FALSE(replay.take(three_four, 2, none, 0));
  btCollisionObject* three[] = {f.owned[2]};
  EXPECT_TRUE(replay.take(three, 1, none, 0));
  ASSERT_TRUE(replay.pending());
  replay.finish(0, 1);
  EXPECT_FALSE(replay.pending());
  for (int i : {0, 1, 2})
    EXPECT_TRUE(same_bits(read_dynamic_state(*f.owned[static_cast<std::size_t>(i)]),
                          f.after.bodies[static_cast<std::size_t>(i)].state));
  EXPECT_TRUE(same_bits(read_dynamic_state(*f.owned[3]), f.before.bodies[3].state));  // not taken
  EXPECT_TRUE(same_bits(read_manifold_state(*f.contact), f.after.manifolds[0]));
}

TEST(IslandReplay, ADifferenceMakesBodiesDirty) {
  Fixture f;
  IslandReplay replay;
  replay.set(StepReplay{&f.before, &f.after, &f.islands});
  // Body 3's state differs from the old run's; the 1-2 contact differs.
  write_dynamic_state(*f.owned[2], moved(f.before.bodies[2].state, btScalar(0.5)));
  ManifoldState other = f.contact_state;
  other.points[0].applied_impulse = 9;
  replay.mark_clean(f.owned, f.descriptions(), {other}, {}, f.before.settings.gravity);
  IslandItems<btPersistentManifold*> held = f.held_of_first();
  IslandItems<btPersistentManifold*> none;
  none.finish(1);
  btCollisionObject* pair[] = {f.owned[0], f.owned[1]};
  btCollisionObject* three[] = {f.owned[2]};
  btCollisionObject* four[] = {f.owned[3]};
  EXPECT_FALSE(replay.take(pair, 2, held, 0));
  EXPECT_FALSE(replay.take(three, 1, none, 0));
  EXPECT_TRUE(replay.take(four, 1, none, 0));
  // A contact in one run only: both its bodies dirty.
  replay.mark_clean(f.owned, f.descriptions(), {}, {}, f.before.settings.gravity);
  EXPECT_FALSE(replay.take(pair, 2, held, 0));
}

// An input removed a joint at this boundary: the old run's islands were
// solved with it. A joint in one run only, or broken in one only, makes its
// bodies dirty; the same joints keep them clean.
TEST(IslandReplay, AJointInOneRunOnlyMakesItsBodiesDirty) {
  Fixture f;
  Joint joint;
  joint.id = 7;
  joint.body_a = 1;
  joint.body_b = 2;
  f.before.joints.push_back(JointSnapshot{joint, false});
  IslandItems<btPersistentManifold*> held = f.held_of_first();
  btCollisionObject* pair[] = {f.owned[0], f.owned[1]};
  IslandReplay replay;
  replay.set(StepReplay{&f.before, &f.after, &f.islands});
  replay.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {JointSnapshot{joint, false}},
                    f.before.settings.gravity);
  EXPECT_TRUE(replay.take(pair, 2, held, 0));
  IslandReplay removed;
  removed.set(StepReplay{&f.before, &f.after, &f.islands});
  removed.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {}, f.before.settings.gravity);
  EXPECT_FALSE(removed.take(pair, 2, held, 0));
  IslandReplay broken;
  broken.set(StepReplay{&f.before, &f.after, &f.islands});
  broken.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {JointSnapshot{joint, true}},
                    f.before.settings.gravity);
  EXPECT_FALSE(broken.take(pair, 2, held, 0));
}

// An input set a joint's motor at this boundary: the same joint, unbroken,
// but its description is not the old run's (the motor's velocity, or a
// 6-DoF axis's max force, differs by one bit): its bodies are dirty.
TEST(IslandReplay, AJointsChangedMotorMakesItsBodiesDirty) {
  Fixture f;
  Joint joint;
  joint.id = 7;
  joint.kind = JointKind::Hinge;
  joint.body_a = 1;
  joint.body_b = 2;
  joint.motor = true;
  joint.motor_velocity = 2.0;
  joint.motor_max_impulse = 1.0;
  f.before.joints.push_back(JointSnapshot{joint, false});
  IslandItems<btPersistentManifold*> held = f.held_of_first();
  btCollisionObject* pair[] = {f.owned[0], f.owned[1]};
  IslandReplay same;
  same.set(StepReplay{&f.before, &f.after, &f.islands});
  same.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {JointSnapshot{joint, false}},
                  f.before.settings.gravity);
  EXPECT_TRUE(same.take(pair, 2, held, 0));
  Joint faster = joint;
  faster.motor_velocity = std::nextafter(2.0, 3.0);
  Joint off = joint;
  off.motor = false;
  Joint axis = joint;
  axis.motor_max_forces[5] = 1.0;
  for (const Joint& changed : {faster, off, axis}) {
    IslandReplay replay;
    replay.set(StepReplay{&f.before, &f.after, &f.islands});
    replay.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {JointSnapshot{changed, false}},
                      f.before.settings.gravity);
    EXPECT_FALSE(replay.take(pair, 2, held, 0));
  }
}

// An input changed a body's mass, friction or restitution (or the gravity)
// at this boundary: its raw state agrees with the old run's, but its
// island's step does not, so it is solved.
TEST(IslandReplay, AChangedMaterialOrGravityMakesBodiesDirty) {
  Fixture f;
  IslandReplay replay;
  replay.set(StepReplay{&f.before, &f.after, &f.islands});
  f.descriptions();
  f.now[2].mass = 4;       // body 3
  f.now[3].friction = 0.1;  // body 4
  replay.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {}, f.before.settings.gravity);
  IslandItems<btPersistentManifold*> held = f.held_of_first();
  IslandItems<btPersistentManifold*> none;
  none.finish(1);
  btCollisionObject* pair[] = {f.owned[0], f.owned[1]};
  btCollisionObject* three[] = {f.owned[2]};
  btCollisionObject* four[] = {f.owned[3]};
  EXPECT_FALSE(replay.take(three, 1, none, 0));
  EXPECT_FALSE(replay.take(four, 1, none, 0));
  EXPECT_TRUE(replay.take(pair, 2, held, 0));
  replay.finish(0, 1);
  // Another gravity: nothing is clean.
  Fixture g;
  IslandReplay again;
  again.set(StepReplay{&g.before, &g.after, &g.islands});
  again.mark_clean(g.owned, g.descriptions(), {g.contact_state}, {}, Vec3(0, -1, 0));
  IslandItems<btPersistentManifold*> g_held = g.held_of_first();
  btCollisionObject* g_pair[] = {g.owned[0], g.owned[1]};
  EXPECT_FALSE(again.take(g_pair, 2, g_held, 0));
}

TEST(IslandReplay, ABodyThatLeftIsSolvedAndAManifoldEmptyThenIsEmptied) {
  Fixture f;
  f.after.bodies.erase(f.after.bodies.begin() + 2);  // body 3 left the world in the old run
  f.after.manifolds.clear();                           // the 1-2 manifold ended empty
  IslandReplay replay;
  replay.set(StepReplay{&f.before, &f.after, &f.islands});
  replay.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {}, f.before.settings.gravity);
  IslandItems<btPersistentManifold*> held = f.held_of_first();
  IslandItems<btPersistentManifold*> none;
  none.finish(1);
  btCollisionObject* three[] = {f.owned[2]};
  EXPECT_FALSE(replay.take(three, 1, none, 0));
  EXPECT_FALSE(replay.pending());
  btCollisionObject* pair[] = {f.owned[0], f.owned[1]};
  EXPECT_TRUE(replay.take(pair, 2, held, 0));
  replay.finish(0, 1);
  EXPECT_EQ(f.contact->getNumContacts(), 0);
}

TEST(IslandReplay, VerifyComparesAndNeverWrites) {
  Fixture f;
  IslandReplay replay;
  replay.set(StepReplay{&f.before, &f.after, &f.islands, false, true});
  replay.mark_clean(f.owned, f.descriptions(), {f.contact_state}, {}, f.before.settings.gravity);
  IslandItems<btPersistentManifold*> none;
  none.finish(1);
  btCollisionObject* four[] = {f.owned[3]};
  ASSERT_TRUE(replay.take(four, 1, none, 0));
  EXPECT_THROW(replay.finish(0, 1), std::logic_error);  // still in the before state
  EXPECT_TRUE(same_bits(read_dynamic_state(*f.owned[3]), f.before.bodies[3].state));
  ASSERT_TRUE(replay.take(four, 1, none, 0));
  write_dynamic_state(*f.owned[3], f.after.bodies[3].state);  // as if solved to the old result
  EXPECT_NO_THROW(replay.finish(0, 1));
}

}  // namespace
}  // namespace soda
