// Internal: the bytes of a replay file (docs/replay-format.md is the
// reference; keep the two in step). Chunks' contents before compression:
// the scene header, keyframes and deltas, the index.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "soda/replay/quantise.h"
#include "soda/replay/view_frame.h"

namespace soda::replay {

inline constexpr char kFileMagic[8] = {'S', 'O', 'D', 'A', 'R', 'P', 'L', 'Y'};
inline constexpr char kEndMagic[8] = {'S', 'O', 'D', 'A', 'E', 'N', 'D', '.'};
/// The version this build writes; it reads kOldestVersion .. kFormatVersion.
/// 3: every shape whole (a compound's children, a triangle mesh's and a
/// heightfield's data; before, the box of its local AABB); 2: frames whose
/// set of bodies changes (KEYF population, BODS chunks, the index's list of
/// BODS chunks); 1: a fixed set of bodies.
inline constexpr std::uint32_t kFormatVersion = 3;
inline constexpr std::uint32_t kOldestVersion = 1;
inline constexpr std::size_t kFileHeaderBytes = 16;   // magic, version, flags (0)
inline constexpr std::size_t kChunkHeaderBytes = 16;  // tag, raw size, stored size, CRC-32
inline constexpr std::size_t kTrailerBytes = 16;      // index chunk offset, end magic
/// Largest raw chunk the reader accepts (a corrupted size must not make it
/// allocate without bound): 1 GiB, far above any frame (16 bytes a body).
inline constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{1} << 30;

/// Chunk tags: four ASCII letters, read as a little-endian u32.
constexpr std::uint32_t tag(const char (&s)[5]) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(s[0])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[1])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[2])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[3])) << 24;
}
inline constexpr std::uint32_t kHeaderTag = tag("HEAD");
inline constexpr std::uint32_t kKeyframeTag = tag("KEYF");
inline constexpr std::uint32_t kDeltaTag = tag("DELT");
inline constexpr std::uint32_t kIndexTag = tag("INDX");
inline constexpr std::uint32_t kBodiesTag = tag("BODS");

/// One frame as the file holds it (quantised); for a delta, the state after
/// applying it. cell_owner is always the map in force.
struct StoredFrame {
  std::int64_t step = 0;
  std::optional<std::vector<BodyId>> ids;  // the bodies of the arrays; nullopt: the header's dynamic ones
  PositionBox box;                      // the keyframe's
  std::vector<std::uint16_t> position;  // 3 codes per body
  std::vector<std::uint32_t> orientation;
  std::vector<std::uint8_t> sleeping;
  std::vector<std::uint16_t> owner;
  std::vector<std::uint16_t> cell_owner;
  bool map_changed = false;             // the map was stored with this frame
  std::vector<float> world_busy_ms;
  std::optional<std::uint64_t> state_hash;
};

/// What every frame of a file has in common (from its header).
struct FrameShape {
  std::size_t bodies = 0;  // dynamic bodies of the header (a frame whose ids are empty has these)
  int worlds = 1;
  std::size_t cells = 0;   // box cells (0 for an invalid box)
};
FrameShape frame_shape(const ViewHeader& header);

std::vector<std::uint8_t> encode_header(const ViewHeader& header, std::uint32_t keyframe_every);
/// A file of `version`'s header. Throws FormatError.
ViewHeader decode_header(std::span<const std::uint8_t> raw, std::uint32_t version, std::uint32_t& keyframe_every);

/// Bodies added after the header (BODS): their descriptions, ascending id.
std::vector<std::uint8_t> encode_bodies(const std::vector<ViewBody>& bodies);
/// Throws FormatError (a static body, ids not ascending).
std::vector<ViewBody> decode_bodies(std::span<const std::uint8_t> raw, std::uint32_t version);

std::vector<std::uint8_t> encode_keyframe(const StoredFrame& frame);
/// `prev`: the frame before `frame` (same box, same ids).
std::vector<std::uint8_t> encode_delta(const StoredFrame& prev, const StoredFrame& frame);
/// Replaces `state` with the keyframe of a file of `version`. Throws
/// FormatError.
void decode_keyframe(std::span<const std::uint8_t> raw, const FrameShape& shape, std::uint32_t version,
                     StoredFrame& state);
/// Applies the delta to `state` (the frame before it: its bodies are the
/// delta's). Throws FormatError.
void decode_delta(std::span<const std::uint8_t> raw, const FrameShape& shape, StoredFrame& state);

/// The frame a stored one stands for (positions and orientations decoded).
ViewFrame to_view_frame(const StoredFrame& frame);

/// zlib (deflate) at `level`; CRC-32 as zlib computes it.
std::vector<std::uint8_t> deflate_bytes(std::span<const std::uint8_t> raw, int level);
/// Throws FormatError unless `stored` inflates to exactly raw_size bytes.
std::vector<std::uint8_t> inflate_bytes(std::span<const std::uint8_t> stored, std::size_t raw_size);
std::uint32_t crc32_of(std::span<const std::uint8_t> bytes);

}  // namespace soda::replay
