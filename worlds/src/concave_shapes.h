// Internal: the Bullet shapes of static triangle meshes and heightfields,
// built once per process and shared read-only by every world and body that
// holds them (docs/scene-format.md, "Triangle meshes and heightfields").
//
// A mesh's Bullet copy (vertices in btScalar, int indices) and its BVH
// (btBvhTriangleMeshShape, quantized) are built the first time a world asks
// for the shape of a TriangleMeshData, and handed out again, as long as
// some world holds it, to every world that asks for the same data (a
// scene's copies share one TriangleMeshData, so every territory of a run
// does). A heightfield's heights likewise. Why sharing is safe: collision
// detection only reads a concave shape (its AABB, its BVH walk, its
// triangles); nothing in SODA or Bullet's narrowphase writes to it after it
// is built, so worlds on any threads may read it at once. Why it is exact:
// the shape is a pure function of the data (the BVH build is
// deterministic), so whichever world built it, the triangles a query
// visits and their order are the same.
//
// A part (MeshCut, HeightfieldData::Window: what an MPI rank holds) answers
// as the whole does wherever it holds the triangles: a mesh visits the
// triangles under a box in the order of their index in the whole mesh
// (not its BVH's, which depends on every triangle the tree holds) and
// reports them by that index, with the whole's AABB; a heightfield window
// keeps the whole grid's frame and answers for the samples it holds, and
// throws std::logic_error for one it does not (a cut too small: a bug,
// never a silent miss).
#pragma once

#include <cstddef>
#include <memory>

#include <btBulletCollisionCommon.h>

#include "soda/scene/scene.h"

namespace soda {

/// The process's shared Bullet shape of a TriangleMesh or Heightfield
/// shape (kept alive by the pointers handed out; thread-safe).
std::shared_ptr<btCollisionShape> shared_concave_shape(const Shape& shape);

/// The same for the stock world (--world stock): a mesh in Bullet's own
/// order (its BVH's), as stock Bullet runs it; a heightfield is the shared
/// one. Throws std::invalid_argument for a part of a mesh.
std::shared_ptr<btCollisionShape> stock_concave_shape(const Shape& shape);

/// Bytes the shared Bullet shape of `shape` holds (its vertices, indices or
/// heights in btScalar and its BVH nodes): what a process pays once,
/// whatever the number of worlds.
std::size_t concave_shape_bytes(const Shape& shape);

}  // namespace soda
