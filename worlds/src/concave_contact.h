// Internal: contacts between a convex body and a static triangle mesh or
// heightfield in SODA's worlds, one manifold per pair in the pair's body
// order (docs/scene-format.md, "Triangle meshes and heightfields").
//
// Bullet's convex-concave algorithm keeps its manifold as (convex body,
// concave body) whatever the pair's order, and tests each triangle with
// the convex body first. SODA's contact state is one manifold per pair of
// bodies in id order (pair_manifold.h: what ghosts seed, migrations carry,
// snapshots and rollbacks restore), and a static terrain usually has the
// smaller id. So a convex-concave pair has SODA's algorithm: Bullet's, step
// for step — the convex body's box in the concave shape's frame grown by
// the shape's margin, the triangles under it in the shape's own order
// (a mesh's: its triangles' order in the whole mesh, whether a process holds
// the whole or a part; a heightfield's: its grid's), each tested by its Bullet
// triangle algorithm into the one manifold, then the manifold refreshed —
// but with the manifold in the order the pair is given and each triangle
// tested with the bodies in that order. Given a manifold (a compound's
// child), it adds to that one and leaves the refresh to its owner. Points
// carry the triangle's part and index (Bullet's partId / index).
//
// Every world that holds the pair makes the same tests in the same order
// from the same shapes and poses. The stock world (--world stock) keeps
// Bullet's own algorithm.
#pragma once

#include <btBulletCollisionCommon.h>

namespace soda {

/// Registers the algorithm above for every pair of a convex shape type and
/// a triangle mesh or heightfield, both orders, on `dispatcher`. The create
/// functions are static and stateless: any number of dispatchers on any
/// threads may use them.
void register_concave_algorithms(btCollisionDispatcher& dispatcher);

}  // namespace soda
