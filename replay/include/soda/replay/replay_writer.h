// replay/ — replay files (docs/replay-format.md). This header: writing one.
//
//   soda::replay::ReplayWriter out("run.replay", header);
//   out.describe(body);                                // a body added later by an input
//   for (const ViewFrame& f : frames) out.append(f);   // steps ascending
//   out.close();                                       // index + end marker
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "soda/replay/quantise.h"
#include "soda/replay/replay_error.h"
#include "soda/replay/view_frame.h"

namespace soda::replay {

struct ReplayWriterOptions {
  /// Frames from one keyframe to the next (>= 1); a frame with a body
  /// outside the current keyframe's position box starts one early. 60: one
  /// second of a 60 Hz run, so a seek decodes at most 59 deltas.
  int keyframe_every = 60;
  /// zlib level, 1 (fastest) .. 9 (smallest). 1: recording runs beside the
  /// worlds; higher levels cost more CPU for a few per cent of size
  /// (docs/replay-format.md, "Cost").
  int compression_level = 1;
};

struct StoredFrame;  // internal (replay/src/replay_codec.h)

/// Appends frames to a new replay file. The file is complete (readable by
/// ReplayReader) once close() returns; a writer destroyed without close()
/// closes it, swallowing errors (call close() to see them).
/// Thread safety: one thread at a time.
class ReplayWriter {
 public:
  /// Creates (truncates) `path` and writes the file header and `header`.
  /// Throws ReplayError naming the path if it cannot be opened or written,
  /// std::invalid_argument for a header that cannot be stored (territories
  /// outside 1 .. 65535, ids not ascending, bad options).
  ReplayWriter(std::string path, ViewHeader header, ReplayWriterOptions options = {});
  ~ReplayWriter();
  ReplayWriter(const ReplayWriter&) = delete;
  ReplayWriter& operator=(const ReplayWriter&) = delete;

  /// Describes a dynamic body that is not in the header (one an input adds
  /// during the run), so that frames may hold it: its description is
  /// written once, before the first frame that holds it (a BODS chunk).
  /// Describe it before that frame is appended; describing bodies that no
  /// frame ever holds costs nothing. Throws std::invalid_argument for a
  /// static body, an id of the header, or an id described before with
  /// another shape (the same description again is ignored).
  void describe(const ViewBody& body);

  /// Quantises `frame` and appends it (a keyframe or a delta against the
  /// previous frame; a keyframe whenever its bodies are not the previous
  /// frame's). Its step must exceed the previous frame's; `ids` empty (the
  /// header's dynamic bodies) or ascending ids, each a dynamic body of the
  /// header or described; its arrays sized for its bodies (per body: 3
  /// positions, 4 orientation components, a sleep flag, an owner <
  /// territories; world_busy_ms empty or one per world; cell_owner empty or
  /// one per box cell, and given on the first frame when the box has
  /// cells). Throws std::invalid_argument naming the step, body id and field
  /// for a frame that breaks these or holds a non-finite position or
  /// orientation (the file is left as before the call), ReplayError for an
  /// I/O failure, and std::logic_error after close().
  void append(const ViewFrame& frame);

  /// Writes the index and the end marker and closes the file. Throws
  /// ReplayError on an I/O failure. Idempotent.
  void close();

  /// The last appended frame as the file stores it: what ReplayReader
  /// returns for its step, bit for bit (positions and orientations
  /// dequantised; cell_owner the map in force). std::logic_error before
  /// the first append.
  ViewFrame stored_frame() const;
  /// The position box of the last appended frame (its keyframe's).
  PositionBox stored_box() const;

  const std::string& path() const { return path_; }
  std::size_t frames() const { return index_.size(); }
  std::size_t keyframes() const;
  /// Bytes written so far (the whole file once closed).
  std::uint64_t bytes() const { return offset_; }

 private:
  struct IndexEntry {
    std::int64_t step;
    std::uint64_t offset;
    bool key;
    PositionBox box;
  };
  void write_chunk(std::uint32_t tag, const std::vector<std::uint8_t>& raw);
  void write_bytes(const void* data, std::size_t size);
  /// Checks `frame`; returns the ids it holds that no chunk has described
  /// yet (their descriptions are in described_).
  std::vector<BodyId> check(const ViewFrame& frame) const;

  std::string path_;
  ViewHeader header_;
  std::vector<BodyId> header_ids_;  // the header's dynamic bodies, ascending
  /// Bodies described by describe(): whether a BODS chunk holds them yet.
  struct Described {
    ViewBody body;
    bool written = false;
  };
  std::map<BodyId, Described> described_;
  std::vector<std::uint64_t> bodies_chunks_;  // offsets of the BODS chunks
  ReplayWriterOptions options_;
  std::FILE* file_ = nullptr;
  std::uint64_t offset_ = 0;
  std::vector<IndexEntry> index_;
  std::unique_ptr<StoredFrame> last_;  // the previous frame as stored
  int since_key_ = 0;
};

}  // namespace soda::replay
