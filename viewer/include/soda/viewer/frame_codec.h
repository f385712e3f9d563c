// viewer/ — what the frame server sends to the browser: the ViewHeader as
// JSON and a ViewFrame as JSON or as a compact little-endian binary record.
// Pure functions of their arguments; safe from any thread. The layouts are
// documented in docs/viewer.md ("Wire format") and read by
// viewer/web/protocol.js.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "soda/replay/view_frame.h"

namespace soda::viewer {

/// Magic of a binary frame ("SVF1" in its first four bytes).
inline constexpr char kFrameMagic[4] = {'S', 'V', 'F', '1'};
/// Bytes of the binary frame's fixed header, before the arrays: a multiple
/// of 8 so that every array after it starts aligned for its typed view.
inline constexpr std::size_t kFrameHeaderBytes = 40;
/// Flag bits of a binary frame.
inline constexpr std::uint32_t kFrameHasHash = 1u;   // state_hash holds the run's hash
inline constexpr std::uint32_t kFrameFinished = 2u;  // the source will add no frame
inline constexpr std::uint32_t kFrameHasIds = 4u;    // u32 ids[n] follow the header: not the header's bodies

/// The header as JSON: {"format":"soda-view-header","version":1, scene,
/// seed (string, 64-bit exact), dt, territories, dynamic_count, grid
/// {origin, cell_size}, box {lo, hi}, bodies [{id, static, shape {kind,
/// half_extents, radius, height, points}, position, orientation [x,y,z,w]}]}.
nlohmann::json header_json(const replay::ViewHeader& header);

/// One body as header_json lists it: {id, static, shape, position,
/// orientation}. What `/bodies` answers for bodies added during a run.
nlohmann::json body_json(const replay::ViewBody& body);

/// The frame as JSON (tests, debugging): step, ids (null: the header's
/// dynamic bodies), position, orientation, sleeping, owner, cell_owner,
/// world_busy_ms, state_hash (16 hex digits or null), finished.
nlohmann::json frame_json(const replay::ViewFrame& frame, bool finished);

/// The frame as the binary record of docs/viewer.md: a 40-byte header
/// (magic, u32 flags, i64 step, u32 n, u32 b, u32 c, u32 0, u64 state_hash), then
/// u32 ids[n] if flag kFrameHasIds, f32 position[3n], f32 orientation[4n],
/// f32 world_busy_ms[b], u16 owner[n], u16 cell_owner[c], u8 sleeping[n],
/// little-endian. Throws std::invalid_argument if the per-body arrays
/// disagree on n.
std::string frame_binary(const replay::ViewFrame& frame, bool finished);

}  // namespace soda::viewer
