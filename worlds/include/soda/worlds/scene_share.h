// A process's share of a scene: what the territory worlds it builds hold at
// their start, and nothing that only other processes' worlds hold.
#pragma once

#include <functional>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"

namespace soda {

/// The part of `scene` that the worlds `keep` accepts hold when built from
/// it (TerritoryWorld(scene, w, map)): every static and kinematic body (each
/// world knows every static), the dynamic bodies whose home world is kept,
/// and every joint but those between dropped bodies. A fixed static
/// triangle mesh or heightfield is cut to the triangles the kept worlds may
/// meet (those within reach + 1 cells of their cells; a MeshCut or a
/// HeightfieldData::Window), which give those worlds the same contacts as
/// the whole (docs/mpi.md, "What a rank holds"). A dynamic body's home
/// world owns the cell of its position as Bullet holds it (rounded to
/// btScalar); a joint group's is its anchor's (its smallest dynamic id). A
/// kept world built from the share holds exactly what it holds when built
/// from the whole scene; a dropped world holds no dynamic body. Bodies and
/// joints stay in the scene's order; settings and name are the scene's.
///
/// Used by a rank of an MPI run (docs/mpi.md, "What a rank holds"), whose
/// worlds are built from its share while the rest of the scene is freed.
/// `cut_level_geometry` false keeps every mesh and heightfield whole (a run
/// whose cessions move cells between ranks' worlds needs them all).
Scene scene_share(const Scene& scene, const TerritoryMap& map, const std::function<bool(WorldId)>& keep,
                  bool cut_level_geometry = true);

}  // namespace soda
