// Internal: building and destroying a Bullet world in time linear in its
// bodies (docs/memory.md, "Setup and teardown").
//
// Bullet's own teardown is quadratic: removing one collision object
// (btCollisionWorld::removeCollisionObject, or ~btCollisionWorld, which
// calls cleanProxyFromPairs) walks the *whole* overlapping pair cache to
// find that object's pairs, and removeCollisionObject also finds the object
// in the world's array by a linear search. With N bodies and ~N pairs that
// is N^2 (cube-pile 50,000: 11 s, ~90 % in the pair walk).
//
// release_all_pairs empties the pair cache first, in O(pairs): every
// pair's collision algorithm (and with it its manifold) is freed, the pair
// removed from the back of the array (an O(1) hash removal). After that
// each object's cleanup by ~btCollisionWorld finds no pair to walk, and
// destroying its broadphase proxy is a dbvt leaf removal (O(log N)). So a
// world is torn down by: release_all_pairs, then destroying the Bullet world
// while its bodies are still alive (its destructor reads them), then the
// bodies.
#pragma once

#include <btBulletDynamicsCommon.h>

namespace soda {

/// Frees every overlapping pair of `broadphase` with its collision
/// algorithm and manifold, in time linear in the pairs. The world's bodies
/// stay in the world (their proxies have no pairs left); call it right
/// before destroying the world. Results of a world that goes on stepping
/// would change (contact history is gone), so only for teardown.
/// Not thread-safe: the caller owns the world.
void release_all_pairs(btBroadphaseInterface& broadphase, btDispatcher& dispatcher);

}  // namespace soda
