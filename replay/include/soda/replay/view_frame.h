// replay/ — what a viewer sees of a run: the contract between the things that
// produce frames (a replay file, a live Simulation) and the things that show
// them (the HTTP server behind `soda view` and `soda run --serve`, the
// browser viewer in viewer/). Plain data, float precision (a viewer's), no
// Bullet types, so it builds once for both btScalar precisions.
//
// Producers: replay/ (ReplayReader: a recorded .replay file) and the live
// source over a SceneReader. Consumers: the frame server and `soda view`.
// Neither side knows the other's implementation: only this header.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"

namespace soda::replay {

/// One body as the viewer needs it once per run: its shape, and for statics
/// their (only) pose. Dynamic bodies' poses come in every ViewFrame.
struct ViewBody {
  BodyId id = 0;
  bool is_static = false;
  Shape shape;                        // scene/scene.h, local frame, metres
  Vec3 position = Vec3::Zero();       // initial pose (statics: for ever), m
  Quat orientation = Quat::Identity();
};

/// What stays fixed for a run.
struct ViewHeader {
  std::string scene;                  // scene name (registry name or file stem)
  std::uint64_t seed = 0;
  double dt = 1.0 / 60.0;             // seconds per scene step
  int territories = 1;                // K: worlds, ids 0 .. K-1
  /// Every body of the scene as it starts, ascending id. The dynamic ones,
  /// in this order, are the order of the per-body arrays of every ViewFrame
  /// whose `ids` is empty. Bodies added later by inputs are not here: a
  /// FrameSource describes them (FrameSource::body).
  std::vector<ViewBody> bodies;
  /// The grid and box of the territory map (TerritoryMap::grid(), box()):
  /// ViewFrame::cell_owner holds one owner per box cell in box index order.
  UniformGrid grid;
  CellBox box;

  /// Number of dynamic bodies (the length of a frame's per-body arrays).
  std::size_t dynamic_count() const;
};

/// The scene at one committed step boundary.
struct ViewFrame {
  std::int64_t step = 0;
  /// The dynamic bodies alive at this step, ascending id, when they are not
  /// exactly the header's dynamic bodies (bodies added or removed by
  /// inputs); nullopt when they are. The per-body arrays below run over
  /// these ids, or over the header's dynamic bodies when nullopt.
  std::optional<std::vector<BodyId>> ids;
  /// Per dynamic body, in `ids` order (nullopt: ViewHeader::bodies order,
  /// statics skipped):
  std::vector<float> position;        // 3 floats per body (x, y, z), m
  std::vector<float> orientation;     // 4 floats per body (x, y, z, w), unit
  std::vector<std::uint8_t> sleeping; // 1 if the body is asleep, else 0
  std::vector<std::uint16_t> owner;   // the world owning the body at this step
  /// The territory map in force at this step, one owner per box cell (box
  /// index order), present on the first frame and whenever it changed since
  /// the previous frame; empty otherwise (keep the last one).
  std::vector<std::uint16_t> cell_owner;
  /// Per world: busy CPU in this step, ms (empty if not measured).
  std::vector<float> world_busy_ms;
  /// The run's state hash, on the last frame of a finished run only.
  std::optional<std::uint64_t> state_hash;
};

/// Where frames come from. Implementations are safe to call from several
/// threads at once (the HTTP server's), and never block for long: a live
/// source answers from what is committed, so a slow viewer never slows the
/// worlds down beyond their buffers' capacity.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Fixed for the source's life.
  virtual const ViewHeader& header() const = 0;
  /// The newest frame available now whose step is > after; nullopt if there
  /// is none (yet). Live: the newest committed frame (steps may be skipped).
  virtual std::optional<ViewFrame> newest_after(std::int64_t after) = 0;
  /// The frame at exactly `step`, if this source keeps history (a replay
  /// file); nullopt if not held or never recorded.
  virtual std::optional<ViewFrame> frame_at(std::int64_t step) = 0;
  /// Steps of the first and last frame available now (a live run's last
  /// grows); {0, -1} when there is none yet.
  virtual std::pair<std::int64_t, std::int64_t> step_range() const = 0;
  /// True when no frame will be added any more (a file; a finished run).
  virtual bool finished() const = 0;
  /// The description of body `id`: a body of the header, or one a frame
  /// holds that the header lacks (added during the run); nullopt if the
  /// source knows no such body. This default looks in the header only.
  virtual std::optional<ViewBody> body(BodyId id) const { return header_body(header(), id); }

  /// The header's body `id` (binary search), nullopt if it has none.
  static std::optional<ViewBody> header_body(const ViewHeader& header, BodyId id);
};

inline std::size_t ViewHeader::dynamic_count() const {
  std::size_t n = 0;
  for (const ViewBody& b : bodies) n += b.is_static ? 0 : 1;
  return n;
}

inline std::optional<ViewBody> FrameSource::header_body(const ViewHeader& header, BodyId id) {
  auto it = std::lower_bound(header.bodies.begin(), header.bodies.end(), id,
                             [](const ViewBody& b, BodyId i) { return b.id < i; });
  if (it == header.bodies.end() || it->id != id) return std::nullopt;
  return *it;
}

}  // namespace soda::replay
