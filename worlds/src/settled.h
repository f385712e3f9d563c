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

/// Rule 2 of parking.h: a contact point of `b` can only exist while the two
/// bodies' Bullet AABBs overlap (its shape's contact breaking threshold is at
/// most sqrt(2) * gContactBreakingThreshold, the territory worlds' contract).
bool within_contract(const btRigidBody& b);

}  // namespace soda
