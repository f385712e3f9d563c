// replay/ — replay files (docs/replay-format.md). This header: reading one,
// as a FrameSource (view_frame.h) for the viewer and its server.
//
//   soda::replay::ReplayReader in("run.replay");       // checks the whole layout
//   const ViewHeader& h = in.header();
//   auto [first, last] = in.step_range();
//   for (std::size_t i = 0; i < in.frame_count(); ++i) show(*in.frame_at(in.step_of(i)));
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "soda/replay/quantise.h"
#include "soda/replay/replay_error.h"
#include "soda/replay/view_frame.h"

namespace soda::replay {

struct StoredFrame;  // internal (replay/src/replay_codec.h)

/// A finished replay file, opened for random access. Thread safety: every
/// member may be called from several threads at once (one lock around the
/// file and the decoded frame it keeps).
class ReplayReader final : public FrameSource {
 public:
  /// Opens `path` and reads its file header, scene header and index (not
  /// the frames). Throws ReplayFormatError naming the path and what is
  /// wrong: cannot be opened, not a replay file (magic), another version,
  /// truncated or never closed (no end marker), a chunk whose checksum or
  /// contents do not hold, an index out of order.
  explicit ReplayReader(std::string path);
  ~ReplayReader() override;
  ReplayReader(const ReplayReader&) = delete;
  ReplayReader& operator=(const ReplayReader&) = delete;

  // FrameSource ---------------------------------------------------------------
  const ViewHeader& header() const override { return header_; }
  /// The last frame if its step is > after, else nullopt (a file: nothing
  /// newer ever comes; play a file with frame_at).
  std::optional<ViewFrame> newest_after(std::int64_t after) override;
  /// The frame recorded at `step`, nullopt if none was. Decodes from the
  /// keyframe at or before it (or from the frame last decoded, when that is
  /// on the way): reading forwards costs one delta a frame. cell_owner is
  /// always the territory map in force at `step` (random access has no
  /// "previous frame"). Throws ReplayFormatError naming the path, the step
  /// and what is wrong for a frame that does not decode.
  std::optional<ViewFrame> frame_at(std::int64_t step) override;
  /// {first step, last step}; {0, -1} for a file without frames.
  std::pair<std::int64_t, std::int64_t> step_range() const override;
  bool finished() const override { return true; }
  /// A body of the header or one added during the run (added_bodies()).
  std::optional<ViewBody> body(BodyId id) const override;

  // The file -----------------------------------------------------------------
  const std::string& path() const { return path_; }
  /// Format version: 2 (what this build writes: bodies may come and go) or
  /// 1 (a fixed set of bodies; read as before).
  std::uint32_t version() const { return version_; }
  /// The bodies frames hold that the header lacks (added by inputs during
  /// the run), ascending id, as described when they first appeared.
  const std::vector<ViewBody>& added_bodies() const { return added_; }
  std::uint64_t file_bytes() const { return file_bytes_; }
  std::size_t frame_count() const { return index_.size(); }
  std::size_t keyframe_count() const;
  /// The writer's keyframe interval (ReplayWriterOptions::keyframe_every).
  int keyframe_every() const { return keyframe_every_; }
  /// Step of the i-th frame (i < frame_count()), ascending.
  std::int64_t step_of(std::size_t i) const { return index_.at(i).step; }
  /// The position box the frame at `step` is quantised in (its keyframe's);
  /// nullopt if no frame has that step.
  std::optional<PositionBox> box_at(std::int64_t step) const;
  /// Largest position_error_bound over the file's keyframe boxes, metres.
  double position_error_bound() const;

 private:
  struct IndexEntry {
    std::int64_t step;
    std::uint64_t offset;
    bool key;
    std::size_t keyframe;  // index of its keyframe's entry
    PositionBox box;       // its keyframe's
  };
  std::vector<std::uint8_t> read_chunk(std::uint64_t offset, std::uint32_t want_tag, const std::string& what) const;
  void read_bytes(std::uint64_t offset, void* out, std::size_t size, const std::string& what) const;
  [[noreturn]] void fail(const std::string& what) const;
  std::optional<std::size_t> find(std::int64_t step) const;
  bool body_known(BodyId id) const;  // a dynamic body of the header or added_
  ViewFrame decode_locked(std::size_t i);

  std::string path_;
  int fd_ = -1;
  std::uint64_t file_bytes_ = 0;
  std::uint32_t version_ = 0;
  int keyframe_every_ = 1;
  ViewHeader header_;
  std::vector<ViewBody> added_;  // from the BODS chunks, ascending id
  std::vector<IndexEntry> index_;
  std::mutex mutex_;                     // guards the two below and the decoding
  std::unique_ptr<StoredFrame> state_;   // the frame last decoded
  std::size_t state_index_ = 0;          // its index entry
};

}  // namespace soda::replay
