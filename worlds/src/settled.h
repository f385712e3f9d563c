// Internal: the "settled" test shared by parking (parking.h, the canonical
// world) and idle territories (TerritoryWorld::idle_ready, docs/skip.md).
#pragma once

#include <btBulletDynamicsCommon.h>

namespace soda {

/// True if every component of `v` is +0, bit for bit (not -0).
bool zero_bits(const btVector3& v);

/// True if a step leaves `b`'s state as it is, bit for bit: ISLAND_SLEEPING
/// with a sleep timer > 0, velocities +0 (the bits a step's
/// updateActivationState writes), and its interpolation transform equal, bit
/// for bit, to what the next step's prediction writes
/// (btTransformUtil::integrateTransform of its transform at zero velocity
/// over `h` seconds). Such a body gets no gravity, no solve and no
/// integration; damping and prediction rewrite the same bits.
bool body_settled(const btRigidBody& b, btScalar h);

}  // namespace soda
