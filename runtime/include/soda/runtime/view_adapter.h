// runtime/ — the embedding API. This header: a run as a viewer sees it
// (replay/view_frame.h), from a Scene, its TerritoryMap and the SceneFrames
// a SceneReader reads. Used by `soda run --record` (replay files) and meant
// for live FrameSources (`soda run --serve`). Needs btScalar (SceneFrame),
// hence here and not in replay/.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/replay/view_frame.h"
#include "soda/runtime/scene_reader.h"
#include "soda/scene/scene.h"

namespace soda {

/// The viewer's header of a run of `scene` cut by `map`: every body in
/// ascending id (shapes, statics' poses, dynamics' initial poses), dt, seed,
/// K = map.world_count(), the map's grid and box. Throws
/// std::invalid_argument for two bodies with one id. Pure; thread-safe.
replay::ViewHeader view_header(const Scene& scene, const TerritoryMap& map);

/// The map's owners as ViewFrame::cell_owner: one per box cell, in box
/// index order. Throws std::invalid_argument if the map has more worlds than
/// 16 bits hold. Pure; thread-safe.
std::vector<std::uint16_t> view_cell_owner(const TerritoryMap& map);

/// A body as the viewer describes it: id, shape, pose (where it starts).
/// For bodies an input adds during a run (ReplayWriter::describe,
/// LiveFrameSource::describe). Pure; thread-safe.
replay::ViewBody view_body(const Body& body);

/// `frame` as a viewer sees it: positions and orientations rounded to
/// float, sleep flags, owners (SceneFrame::owners), per-world busy time in
/// ms (SceneFrame::busy_seconds), and cell_owner = view_cell_owner(*map) if `map` is
/// given (else empty: "unchanged"). Its bodies are the frame's poses
/// (ascending id): ids is nullopt when they are exactly the header's
/// dynamic bodies, else the poses' ids (bodies added or removed by inputs).
/// Throws std::invalid_argument naming the step and body for poses not in
/// ascending id order or owners that do not match them. Pure; thread-safe.
replay::ViewFrame view_frame(const SceneFrame& frame, const replay::ViewHeader& header,
                             const TerritoryMap* map = nullptr);

}  // namespace soda
