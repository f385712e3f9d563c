// Internal: one manifold per pair for compound shapes, in every SODA world
// (docs/scene-format.md, "Compound shapes").
//
// Bullet's compound algorithms give each touching child its own manifold,
// so a pair of bodies may hold several, and they call a child's test with
// the compound's child first. SODA's contact state is one manifold per pair
// of bodies in id order — what ghosts seed, migrations carry, snapshots and
// rollbacks restore and islands are built from (pair_manifold.h) — so a
// pair that holds a compound here has one algorithm of SODA's own: it makes
// the pair's manifold when it is made (as Bullet's box-box algorithm does),
// refreshes it before the children add points (as Bullet refreshes its
// child manifolds), and tests every pair of children whose AABBs overlap
// (a convex body is its own only child) with that child pair's Bullet
// algorithm, in child order, the bodies in the manifold's order, all into
// that one manifold. Points carry the child's index (Bullet's index0 /
// index1). Up to four points per pair, as for any manifold: a chair
// standing on its four legs keeps one per leg.
//
// Every world that holds the pair makes the same tests in the same order
// from the same shapes and poses. The stock world (--world stock) keeps
// Bullet's own compound algorithms (a manifold per child).
#pragma once

#include <btBulletCollisionCommon.h>

namespace soda {

/// Registers the shared-manifold compound algorithms for every pair of
/// shape types that holds a compound (compound-convex, convex-compound,
/// compound-compound) on `dispatcher`, and box-box and sphere-sphere create
/// functions that use a manifold they are given (Bullet's drop it; for a
/// pair of bodies, given none, they make what Bullet's make). The create functions are static and
/// stateless: any number of dispatchers on any threads may use them.
void register_compound_algorithms(btCollisionDispatcher& dispatcher);

}  // namespace soda
