// Internal: the contact breaking threshold of every manifold of a SODA world
// (CanonicalWorld, TerritoryWorld): Bullet's, capped so that bodies of any
// size stay inside the exactness contract (docs/determinism.md, "Bodies of
// any size").
//
// Bullet gives a manifold the smaller of its two shapes' thresholds,
// getContactBreakingThreshold(gContactBreakingThreshold) = bounding radius *
// gContactBreakingThreshold (0.02 per metre of radius). A point survives
// while its two ends stay within the threshold, and the exactness of the
// step (one world or many) rests on this: a manifold point can only exist
// while the two bodies' Bullet AABBs — each grown by
// gContactBreakingThreshold — overlap: a kept point is within the threshold t
// along the normal and across it, so its two ends are at most sqrt(2) * t
// apart, which must stay below the 2 * gContactBreakingThreshold the AABBs
// were grown by together, i.e. t <= sqrt(2) * gContactBreakingThreshold.
// Beyond it (a bounding radius
// above about 1.41 m: a 2 m box, a car, a ship) whether a point survives
// would depend on the broadphase's history, even in one world. So the
// threshold is capped at kMaxBreakingThreshold, fixed before the manifold
// exists (CappedDispatcher) and identical in every world and every copy:
//  1. a body whose bounding radius is at most sqrt(2) m gets Bullet's own
//     threshold, bit for bit (every scene of unit-sized bodies is unchanged);
//  2. a larger body's manifolds break at sqrt(2) * gContactBreakingThreshold
//     (2.8 cm), as though it were a body of radius sqrt(2) m: points are
//     dropped a little sooner than stock Bullet would drop them, the
//     behaviour of Bullet without relative thresholds.
#pragma once

#include <btBulletCollisionCommon.h>

#include "compound_contact.h"
#include "concave_contact.h"

namespace soda {

/// The largest contact breaking threshold inside the exactness contract,
/// metres: sqrt(2) * gContactBreakingThreshold.
btScalar max_breaking_threshold();

/// The breaking threshold of a manifold between `a` and `b`:
/// min(Bullet's relative threshold of either shape, max_breaking_threshold()).
btScalar manifold_breaking_threshold(const btCollisionObject& a, const btCollisionObject& b);

/// A btCollisionDispatcher whose new manifolds break at
/// manifold_breaking_threshold (everything else as Bullet's).
/// Compound pairs keep one manifold (compound_contact.h), and so do
/// convex-concave pairs, in the pair's order (concave_contact.h).
class CappedDispatcher : public btCollisionDispatcher {
 public:
  explicit CappedDispatcher(btCollisionConfiguration* config) : btCollisionDispatcher(config) {
    register_compound_algorithms(*this);
    register_concave_algorithms(*this);
  }
  btPersistentManifold* getNewManifold(const btCollisionObject* b0, const btCollisionObject* b1) override;
};

}  // namespace soda
