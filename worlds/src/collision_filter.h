// Internal: the collision filter of SODA's worlds (Body::collision_group and
// collision_mask, docs/scene-format.md "Collision filtering").
//
// A body's proxy carries its group and mask (add_body_with_canonical_proxy);
// the pair cache asks BodyFilter before it adds a pair, so a filtered pair
// never gets a pair, an algorithm, a manifold or an island edge. The test
// reads only the two bodies' own filters and static flags: every world that
// holds both bodies (owner, ghost, one world or K) decides a pair alike.
#pragma once

#include <cstdint>

#include <btBulletDynamicsCommon.h>

#include "soda/scene/scene.h"

namespace soda {

/// Bullet's proxy fields are int: the filter's 32 bits, as they are.
inline int proxy_bits(std::uint32_t bits) { return static_cast<int>(bits); }

/// True if the pair may collide: each body's group is in the other's mask,
/// neither is a sensor (mark_sensor: a sensor touches nothing; SensorReader
/// reports its overlaps from committed frames), and not both are static or
/// kinematic (Bullet's default filter keeps those apart too: addRigidBody
/// gives them StaticFilter, masked out of each other).
inline bool bodies_may_collide(const btBroadphaseProxy* a, const btBroadphaseProxy* b) {
  if ((a->m_collisionFilterGroup & b->m_collisionFilterMask) == 0 ||
      (b->m_collisionFilterGroup & a->m_collisionFilterMask) == 0)
    return false;
  const auto* oa = static_cast<const btCollisionObject*>(a->m_clientObject);
  const auto* ob = static_cast<const btCollisionObject*>(b->m_clientObject);
  if (!oa->hasContactResponse() || !ob->hasContactResponse()) return false;
  return !(oa->isStaticOrKinematicObject() && ob->isStaticOrKinematicObject());
}

/// The overlap filter of every SODA world and of the stock world.
struct BodyFilter final : btOverlapFilterCallback {
  bool needBroadphaseCollision(btBroadphaseProxy* a, btBroadphaseProxy* b) const override {
    return bodies_may_collide(a, b);
  }
};

}  // namespace soda
