// Internal: continuous collision detection inside the exactness contract
// (docs/ccd.md). Bullet's own CCD (btDiscreteDynamicsWorld::integrateTransforms
// clamping each fast body's motion by a sweep against the whole broadphase,
// other bodies taken as they are *during* integration) depends on the order
// in which bodies are integrated and on everything else in the world; it
// stays off (every body's CCD motion threshold is 0).
//
// In its place, per broadphase pair: when either body is *fast* (it moves
// more than its sweep radius in the step) and the pair's narrowphase found no
// point, the fast body's inner sphere is swept along the pair's relative
// motion against the other body; a hit becomes one *speculative* contact
// point in the pair's manifold (distance = the gap left along the normal,
// no friction, no restitution), which the island solve turns into "approach
// no faster than gap / h". The point is a pure function of the pair's two
// bodies at the step's start (transforms, predicted transforms, shapes), so
// every world that holds the pair makes the same one; every body whose
// volume meets the sweep has its AABB (the halo: current ∪ predicted
// transform) overlapping the fast body's, so the pair exists wherever the
// fast body's pairs are held; and the solve is the island's, in its
// canonical order. The points live from collide to the start of integrate:
// clear_speculative_contact() removes them before anything is integrated,
// migrated, kept or snapshotted.
//
// Thread safety: functions of their arguments; each call touches only the
// manifold it is given.
#pragma once

#include <btBulletDynamicsCommon.h>

#include "soda/worlds/world_snapshot.h"

namespace soda {

/// Bit of btManifoldPoint::m_contactPointFlags (and
/// ContactPointState::contact_point_flags) marking a speculative point.
/// Bullet's own flags use bits 0..4 and test them one by one.
inline constexpr int kSpeculativeContactFlag = 1 << 12;

/// True if a dynamic body moves more than its sweep radius (its ccd swept
/// sphere radius: inner_radius() of its shape, bullet_bodies.h) in the step: the
/// distance between its world transform's origin and its interpolation
/// (predicted) transform's. Slower bodies meet any surface in a discrete
/// step before their inner sphere can cross it (two spheres of radius r
/// whose centres are at most r apart cover the segment between them).
bool is_fast(const btCollisionObject& body);

/// After the narrowphase of a pair whose manifold has no point: if either
/// body is fast, sweeps it (both fast: the manifold's body 0) along the
/// relative motion against the other and, on a hit, adds one speculative
/// point. Returns true if it added one.
bool add_speculative_contact(btPersistentManifold& manifold);

/// Removes the manifold's speculative point, if it holds one (it then holds
/// nothing else). Returns true if it did.
bool clear_speculative_contact(btPersistentManifold& manifold);

/// True if a manifold value holds a speculative point.
bool is_speculative(const ManifoldState& manifold);

}  // namespace soda
