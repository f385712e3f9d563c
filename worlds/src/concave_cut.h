// Internal: the part of a static triangle mesh or heightfield that the
// worlds of one MPI rank may meet (scene_share.h; docs/mpi.md, "What a rank
// holds").
//
// A rank's worlds test a triangle only against a body they own, whose halo
// stays within the map's reach of its home cell (a halo beyond it is refused
// before it is used: reach.h), and a triangle that yields a contact point
// overlaps the halo (the point lies within the contact threshold of both).
// So the triangles whose box overlaps a cell within reach + 1 of a cell of
// the rank's worlds (2 reach + 2 for a turned body: the tests run in the
// shape's own frame, where a box grows) are all a rank's worlds can meet;
// the part holds those (a heightfield window one sample more on each side:
// Bullet's grid walk reads a quad beyond the box). Which of them a test visits, and in which order,
// does not depend on the rest: a mesh visits in the whole mesh's triangle
// order, a heightfield window keeps the whole grid's frame
// (concave_shapes.h).
#pragma once

#include <functional>

#include "soda/scene/scene.h"

namespace soda {

/// Whether a world-frame box (lo, hi) may be met by the kept worlds, for a
/// body turned (true) or not.
using NearKeptWorlds = std::function<bool(const Vec3& lo, const Vec3& hi, bool turned)>;

/// `body`'s shape cut to the triangles `near` accepts (at least one: a part
/// is never empty), or the shape itself when every triangle is accepted.
/// For a fixed static's TriangleMesh or Heightfield; other shapes, and
/// parts, are returned as they are.
Shape cut_concave_shape(const Body& body, const NearKeptWorlds& near);

}  // namespace soda
