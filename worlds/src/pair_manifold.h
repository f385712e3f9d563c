// Internal: the manifold of one broadphase pair, created as Bullet creates
// it, for writing contact state into it (canonical restore, territory world
// seeding).
#pragma once

#include <btBulletDynamicsCommon.h>

namespace soda {

/// The pair's one persistent manifold. Creates the pair's algorithm the way
/// btCollisionDispatcher::defaultNearCallback does if it has none (dynamic
/// bodies made active for that moment: box-box algorithms only get a
/// manifold when a body is active), and the manifold the way the algorithm's
/// first processCollision does if it has none yet (convex-convex algorithms,
/// e.g. sphere-box, create it lazily there; the points that call adds are
/// overwritten by the caller). Throws std::logic_error if the pair ends with
/// other than one manifold (compound shapes) or with its bodies in another
/// order than the pair's.
btPersistentManifold& pair_manifold(btBroadphasePair& pair, btCollisionDispatcher& dispatcher,
                                    const btDispatcherInfo& info);

}  // namespace soda
